"""One default per input: ``imu-noise-id simulate``, the demo's robot bag and the node's subscriptions name the same
topics, so that simulate → play → node works with no remap; remaps of the node's inputs still apply."""

from __future__ import annotations

import inspect

import pytest

rclpy = pytest.importorskip("rclpy")

from imu_noise_id.bag.topics import IMU_TYPE, ODOM_TYPE, TEMPERATURE_TYPE, list_topics  # noqa: E402
from imu_noise_id.bag.writer import write_bag, write_robot_bag  # noqa: E402
from imu_noise_id.cli import main  # noqa: E402
from imu_noise_id.demo.online import simulate_demo_run  # noqa: E402


@pytest.fixture
def node_inputs(ros_env, monkeypatch):
    """A function creating the node in this process (loopback DDS, not spun) with ``--ros-args`` items; returns its
    subscriptions as message type → resolved topic, and the node's warning about an old-style IMU remap."""
    from imu_noise_id.ros.node import ImuNoiseIdNode

    for key, value in ros_env.items():
        monkeypatch.setenv(key, value)

    def inputs(*ros_args: str) -> tuple[dict[str, str], str]:
        context = rclpy.Context()
        rclpy.init(context=context)
        try:
            node = ImuNoiseIdNode(context=context, cli_args=["--ros-args", *ros_args] if ros_args else None)
            subs = {}
            for sub in node.subscriptions:
                ns, name = sub.msg_type.__module__.split(".")[0], sub.msg_type.__name__
                subs[f"{ns}/msg/{name}"] = sub.topic_name
            warning = node.stale_imu_remap()
            node.destroy_node()
            return subs, warning
        finally:
            rclpy.shutdown(context=context)

    return inputs


def test_simulate_the_demo_bag_and_the_node_default_to_the_same_topics(tmp_path, capsys, node_inputs):
    assert main(["simulate", "--model", "WN(1e-3)", "--rate", "10", "--duration", "2", "--out",
                 str(tmp_path / "sim"), "--seed", "1"]) == 0  # fmt: skip
    capsys.readouterr()
    simulated = {kind: topic for topic, (kind, _) in list_topics(tmp_path / "sim").items()}
    demo = write_robot_bag(simulate_demo_run(stand_before=0.5, drive=0.5, stand_after=0.5), tmp_path / "demo")
    played = {kind: topic for topic, (kind, _) in list_topics(demo).items()}
    temperature = inspect.signature(write_bag).parameters["temperature_topic"].default

    subscribed, warning = node_inputs()
    assert subscribed == {IMU_TYPE: "/imu/data", ODOM_TYPE: "/odom", TEMPERATURE_TYPE: "/imu/temperature"}
    assert simulated == {IMU_TYPE: subscribed[IMU_TYPE]}
    assert played == {IMU_TYPE: subscribed[IMU_TYPE], ODOM_TYPE: subscribed[ODOM_TYPE]}
    assert temperature == subscribed[TEMPERATURE_TYPE]
    assert warning == ""


def test_the_node_inputs_follow_remaps_and_namespaces(node_inputs):
    subscribed, _ = node_inputs("-r", "imu/data:=/husky/imu", "-r", "odom:=/husky/odom")
    assert subscribed == {IMU_TYPE: "/husky/imu", ODOM_TYPE: "/husky/odom", TEMPERATURE_TYPE: "/imu/temperature"}
    subscribed, _ = node_inputs("-r", "__ns:=/robot")
    assert subscribed == {IMU_TYPE: "/robot/imu/data", ODOM_TYPE: "/robot/odom",
                          TEMPERATURE_TYPE: "/robot/imu/temperature"}


def test_a_remap_of_the_old_imu_input_name_is_warned_about(node_inputs):
    subscribed, warning = node_inputs("-r", "imu:=/husky/imu")
    assert subscribed[IMU_TYPE] == "/imu/data"
    assert "-r imu/data:=/husky/imu" in warning and "does not apply" in warning
    # The old commands' `-r imu:=/imu/data` names the topic the node listens on anyway: nothing to warn about.
    assert node_inputs("-r", "imu:=/imu/data")[1] == ""
