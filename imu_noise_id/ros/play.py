"""Publish a bag's Imu, Odometry and Temperature messages with their original timing (``imu-noise-id play``): in
receive-time order, unchanged, on their recorded topics, paced by receive time / rate; rosbag2 messages as their CDR
bytes, ROS 1 ones converted; reliable publishers with a deep queue (docs/node.md, "``imu-noise-id play`` …").
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from ..core.errors import InputError

#: Message types played, rosbags name → (ROS 2 module, class).
PLAYED_TYPES: dict[str, tuple[str, str]] = {
    "sensor_msgs/msg/Imu": ("sensor_msgs.msg", "Imu"),
    "nav_msgs/msg/Odometry": ("nav_msgs.msg", "Odometry"),
    "sensor_msgs/msg/Temperature": ("sensor_msgs.msg", "Temperature"),
}


def play_bag(bag: Path, *, rate: float = 1.0, loop: bool = False, topics: list[str] | None = None,
             remap: dict[str, str] | None = None, delay: float = 2.0, quiet: bool = True) -> None:
    """Play ``bag`` at ``rate`` × its speed (again and again with ``loop``, until interrupted): ``topics`` (None:
    every Imu, Odometry and Temperature topic), published under ``remap``'s names, after waiting up to ``delay``
    seconds for every topic to have a subscriber.

    Raises
    ------
    InputError
        If the bag cannot be read or a topic is absent or of another type.
    """
    messages = load_messages(bag, topics)
    messages = [(t, topic, kind, data if isinstance(data, bytes) else to_rclpy(data, message_class(kind)))
                for t, topic, kind, data in messages]
    import rclpy

    rclpy.init()
    try:
        node = rclpy.create_node("imu_noise_id_play")
        publishers = _publishers(node, messages, remap or {})
        wait_for_subscribers(node, publishers, delay)
        while True:
            play_once(messages, publishers, rate, quiet=quiet)
            if not loop or not rclpy.ok():
                break
        node.destroy_node()
    finally:
        if rclpy.ok():
            rclpy.shutdown()


def load_messages(bag: Path, topics: list[str] | None) -> list[tuple[int, str, str, Any]]:
    """(receive time [ns], topic, type, data) of the played messages, in bag order; ``data``: CDR bytes (rosbag2) or
    the rosbags message (ROS 1, converted by :func:`to_rclpy` before publishing).

    Raises
    ------
    InputError
        If the bag cannot be opened, a requested topic is absent or has another type, or nothing is playable.
    """
    from rosbags.highlevel import AnyReader

    if not bag.exists():
        raise InputError(f"bag {str(bag)!r} does not exist")
    try:
        reader = AnyReader([bag])
        reader.open()
    except Exception as exc:  # rosbags raises several types for unreadable bags
        raise InputError(f"cannot open bag {str(bag)!r}: {exc}") from None
    try:
        available = {c.topic: c.msgtype for c in reader.connections}
        if topics:
            for topic in topics:
                if topic not in available:
                    raise InputError(f"topic {topic!r} is not in {bag}; it has: {', '.join(sorted(available))}")
                if available[topic] not in PLAYED_TYPES:
                    raise InputError(f"topic {topic!r} has type {available[topic]}: play handles "
                                     f"{', '.join(PLAYED_TYPES)}")
        connections = [c for c in reader.connections if c.msgtype in PLAYED_TYPES
                       and (not topics or c.topic in topics)]
        if not connections:
            raise InputError(f"{bag} has no Imu, Odometry or Temperature topic (topics: "
                             f"{', '.join(f'{t} [{m}]' for t, m in sorted(available.items()))})")
        ros1 = bag.suffix == ".bag"
        out = []
        for connection, timestamp, raw in reader.messages(connections=connections):
            data = reader.deserialize(raw, connection.msgtype) if ros1 else bytes(raw)
            out.append((timestamp, connection.topic, connection.msgtype, data))
    finally:
        reader.close()
    return out


def message_class(msgtype: str) -> type:
    """The rclpy message class of a played rosbags type name."""
    import importlib

    module, cls = PLAYED_TYPES[msgtype]
    return getattr(importlib.import_module(module), cls)


def to_rclpy(src: Any, cls: type) -> Any:
    """An rclpy message of class ``cls`` with the fields of a rosbags message (fields ROS 2 lacks, e.g. ROS 1's
    ``Header.seq``, left out)."""
    import numpy as np

    msg = cls()
    for name in cls.get_fields_and_field_types():
        value = getattr(src, name)
        current = getattr(msg, name)
        if hasattr(current, "get_fields_and_field_types"):
            value = to_rclpy(value, type(current))
        elif isinstance(value, np.ndarray):
            value = value.astype(float)
        setattr(msg, name, value)
    return msg


def _publishers(node: object, messages: list[tuple[int, str, str, Any]], remap: dict[str, str]) -> dict:
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE)
    publishers = {}
    for _, topic, msgtype, _ in messages:
        if topic not in publishers:
            publishers[topic] = node.create_publisher(message_class(msgtype), remap.get(topic, topic), qos)
    return publishers


def wait_for_subscribers(node: object, publishers: dict, timeout: float) -> bool:
    """Spin until every publisher has at least one subscription (True) or ``timeout`` seconds passed (False)."""
    import rclpy

    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if all(pub.get_subscription_count() > 0 for pub in publishers.values()):
            time.sleep(0.2)  # matched on our side; give the other side a moment to match as well
            return True
        rclpy.spin_once(node, timeout_sec=0.05)
    return False


def play_once(messages: list[tuple[int, str, str, Any]], publishers: dict, rate: float, quiet: bool = True) -> None:
    """Publish every message at ``start + (t − t₀)/rate`` on the steady clock (late messages go out at once)."""
    import rclpy

    if not messages:
        return
    t0 = messages[0][0]
    start = time.monotonic()
    last_report = start
    n = len(messages)
    for i, (stamp, topic, _, data) in enumerate(messages):
        target = start + (stamp - t0) * 1e-9 / rate
        delay = target - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        if not rclpy.ok():  # Ctrl-C / SIGTERM: rclpy's signal handler shut the context down
            return
        publishers[topic].publish(data)
        if not quiet and time.monotonic() - last_report > 1.0:
            last_report = time.monotonic()
            print(f"\rplay: {i + 1}/{n} messages, bag time {(stamp - t0) * 1e-9:.1f} s", end="", flush=True)
    if not quiet:
        print(f"\rplay: {n}/{n} messages, bag time {(messages[-1][0] - t0) * 1e-9:.1f} s", flush=True)
