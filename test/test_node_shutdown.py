"""Ctrl-C while a callback runs: the node ends quietly (the demo printed a FATAL 'Exception in timers callback')."""

from __future__ import annotations

import pytest

rclpy = pytest.importorskip("rclpy")


def _imu_message(t: float):
    from sensor_msgs.msg import Imu

    msg = Imu()
    msg.header.stamp.sec, msg.header.stamp.nanosec = int(t), int((t % 1.0) * 1e9)
    msg.header.frame_id = "imu"
    msg.linear_acceleration.z = 9.81
    msg.orientation.w = 1.0
    return msg


def test_callbacks_running_when_the_context_shuts_down_publish_nothing_and_raise_nothing(ros_env, monkeypatch,
                                                                                          capfd):
    from imu_noise_id.ros.node import ImuNoiseIdNode

    for key, value in ros_env.items():
        monkeypatch.setenv(key, value)
    context = rclpy.Context()
    rclpy.init(context=context)
    node = ImuNoiseIdNode(context=context)
    for k in range(50):
        node._on_imu(_imu_message(100.0 + 0.005 * k))
    node._publish_estimates()
    node._publish_diagnostics()
    capfd.readouterr()
    context.shutdown()  # what SIGINT does while the executor is inside a callback
    node._publish_estimates()
    node._publish_diagnostics()
    node._on_imu(_imu_message(100.25))
    err = capfd.readouterr().err
    assert "Failed to publish" not in err and "exception" not in err.lower(), err
    node.destroy_node()
