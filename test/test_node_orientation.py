"""The node reads an Imu message's orientation only where the message has one (REP 145)."""

from __future__ import annotations

import pytest

pytest.importorskip("rclpy")

from sensor_msgs.msg import Imu

from imu_noise_id.ros.node import imu_orientation


def test_a_message_without_orientation_gives_none_and_one_with_it_its_quaternion():
    msg = Imu()
    msg.orientation_covariance[0] = -1.0  # "no orientation estimate" (REP 145); the quaternion left all zero
    assert imu_orientation(msg) is None
    msg.orientation_covariance[0] = 1e-4
    msg.orientation.z, msg.orientation.w = 0.6, 0.8
    assert imu_orientation(msg) == (0.0, 0.0, 0.6, 0.8)
