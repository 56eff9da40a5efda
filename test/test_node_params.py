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


@pytest.mark.parametrize("content", [None, "a: [\n", "imu_noise_id_node: [1, 2]\n"])
def test_a_missing_or_malformed_params_file_is_one_line_and_exit_2(ros_env, monkeypatch, tmp_path, capsys, content):
    from imu_noise_id.ros.node import main

    for key, value in ros_env.items():
        monkeypatch.setenv(key, value)
    path = tmp_path / "params.yaml"
    if content is not None:
        path.write_text(content)
    assert main(["imu_noise_id_node", "--ros-args", "--params-file", str(path)]) == 2
    err = capsys.readouterr().err
    assert "imu_noise_id_node: error:" in err and "params" in err and "Traceback" not in err
