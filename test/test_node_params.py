"""Node parameters as users type them (issue 12): ``-p publish_rate:=20`` is 20.0, not a type error."""

from __future__ import annotations

import pytest

rclpy = pytest.importorskip("rclpy")


def test_integer_overrides_of_floating_point_parameters_are_accepted(ros_env, monkeypatch):
    from rclpy.parameter import Parameter

    from imu_noise_id.ros.node import ImuNoiseIdNode

    for key, value in ros_env.items():
        monkeypatch.setenv(key, value)
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = ImuNoiseIdNode(context=context, parameter_overrides=[
            Parameter("publish_rate", Parameter.Type.INTEGER, 20),
            Parameter("stationary.windw", Parameter.Type.DOUBLE, 2.0),  # misspelled: warned, not fatal
        ])
        assert node.get_parameter("publish_rate").value == 20.0
        assert node.identifier.config.publish_rate == 20.0
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)
