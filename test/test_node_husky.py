"""Replaying the measured Husky bag (robot_localization's test1, ROS 2 conversion) through the node runs clean.

IMU 30 Hz (mounted rotated: gravity on +y), wheel odometry ~10 Hz, 395 s of driving with one 10 s stop; played at
20× speed from another process into the node (own process, the shipped YAML plus the IMU mounting rotation).
"""

from __future__ import annotations

import math
import subprocess
import sys
import time

import pytest

rclpy = pytest.importorskip("rclpy")

from dds import domain_id  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402

from imu_noise_id.core.cmkf import rotation as rot  # noqa: E402
from imu_noise_id.resources import NODE_PARAMETERS, packaged_config  # noqa: E402
from imu_noise_id.ros.launch import stop  # noqa: E402

NODE_CONFIG = packaged_config(NODE_PARAMETERS)

pytestmark = pytest.mark.ros
NODE = "husky_imu_noise_id"
IMU_MESSAGES = 11865
ODOM_MESSAGES = 3952


def _input_counts(arrays: list[DiagnosticArray]) -> tuple[str, str] | None:
    """The latest ``received`` counts of the node's IMU and odometry inputs in its diagnostics."""
    found: dict[str, str] = {}
    for array in arrays:
        for s in array.status:
            for name in ("IMU input", "Odometry input"):
                if s.name == f"{NODE}: {name}":
                    found[name] = next((kv.value for kv in s.values if kv.key == "received"), "")
    return (found["IMU input"], found["Odometry input"]) if len(found) == 2 else None


def test_husky_bag_replays_clean_through_the_node(shared_data, ros_env, tmp_path):
    bag = shared_data / "husky_robot_localization" / "husky_test1_ros2"
    if not bag.is_dir():
        pytest.skip(f"{bag} is absent")
    env = {**ros_env, "ROS_DOMAIN_ID": str(domain_id(10, 99))}
    q = rot.from_ypr(-math.pi / 2, 0.0, math.pi / 2)  # imu_link in base_link (the cmkf developer's Husky value)
    log = tmp_path / "node.log"
    with open(log, "w") as out:
        node = subprocess.Popen(
            [sys.executable, "-m", "imu_noise_id.ros.node", "--ros-args", "--params-file", str(NODE_CONFIG),
             "-r", f"__node:={NODE}", "-r", "imu/data:=/husky/imu", "-r", "odom:=/husky/odom",
             "-p", f"cmkf.imu_rotation_xyzw:=[{q[0]},{q[1]},{q[2]},{q[3]}]"],
            env=env, stdout=out, stderr=subprocess.STDOUT,
        )
        rclpy.init(domain_id=int(env["ROS_DOMAIN_ID"]))
        try:
            observer = rclpy.create_node("husky_observer")
            arrays: list[DiagnosticArray] = []
            observer.create_subscription(DiagnosticArray, "/diagnostics", arrays.append, 50)
            player = subprocess.Popen(
                [sys.executable, "-m", "imu_noise_id", "play", str(bag), "--rate", "20", "--quiet", "--delay", "15",
                 "--topic", "/imu/data", "/husky_velocity_controller/odom",
                 "--remap", "/imu/data:=/husky/imu", "/husky_velocity_controller/odom:=/husky/odom"], env=env,
            )
            end = time.monotonic() + 120
            while player.poll() is None and time.monotonic() < end:
                rclpy.spin_once(observer, timeout_sec=0.05)
            assert player.returncode == 0
            # The node may still be working through its queues on a loaded machine: wait until the inputs' counts
            # in its diagnostics stop growing (at most 30 s), not a fixed time.
            settle, last, seen = time.monotonic() + 30.0, None, 0
            while time.monotonic() < settle:
                rclpy.spin_once(observer, timeout_sec=0.05)
                if len(arrays) > seen:
                    seen = len(arrays)
                    counts = _input_counts(arrays)
                    if counts is not None and counts == last:
                        break
                    last = counts
            assert node.poll() is None, "the node died"
        finally:
            stop(node)
            rclpy.shutdown()
    statuses = {}
    for array in arrays:
        for s in array.status:
            if s.name.startswith(NODE + ": "):
                statuses[s.name[len(NODE) + 2:]] = (s.level[0], s.message, {kv.key: kv.value for kv in s.values})
    received = int(statuses["IMU input"][2]["received"])
    assert received >= 0.99 * IMU_MESSAGES
    # Odometry arrives at 200 Hz here; a node starved of CPU (load 6 on 2 cores) lost up to 2.2 % of it from a
    # subscription queue of 100 (4 % once, on a slower machine), never IMU messages' 1 % from theirs of 1000; the
    # odometry's queue is now as deep.
    assert int(statuses["Odometry input"][2]["received"]) >= 0.97 * ODOM_MESSAGES
    # Clean: no dropped stamps, no CMKF failures, no exceptions in the node's log.
    stamps = statuses["Time stamps"][2]
    assert all(int(v) == 0 for k, v in stamps.items() if k.startswith("total_imu_") and "gap" not in k)
    assert statuses["Filter consistency"][2]["cmkf_restarts_after_errors"] == "0"
    # The CMKF runs; over this drive its verdict is "inconsistent" (planar wheel odometry cannot see the roll and pitch
    # that leak gravity into the accelerometer, docs/node.md "On measured data"), and the node says so at ERROR level.
    level, message, values = statuses["Filter consistency"]
    assert values["cmkf_status"] in ("tracking", "converging", "inconsistent")
    if values["cmkf_status"] == "inconsistent":
        assert level == 2 and "not to be trusted" in message and "Likely cause" in message
    text = log.read_text()
    assert "Traceback" not in text and "not processed" not in text
