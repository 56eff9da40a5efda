"""Opening a bag (ROS 1 ``.bag``, rosbag2 sqlite3 or mcap) and choosing the topics to read; every failure is a
:class:`~.errors.BagError` naming the bag and the topic and saying what to do."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Any

from .errors import BagError

#: The suffixes of a bag file (ROS 1, rosbag2 sqlite3, rosbag2 mcap); a rosbag2 directory has none.
BAG_SUFFIXES = (".bag", ".db3", ".mcap")
IMU_TYPE = "sensor_msgs/msg/Imu"
ODOM_TYPE = "nav_msgs/msg/Odometry"
TEMPERATURE_TYPE = "sensor_msgs/msg/Temperature"

WHAT = {IMU_TYPE: "Imu", ODOM_TYPE: "Odometry", TEMPERATURE_TYPE: "Temperature"}
FLAG = {IMU_TYPE: "--topic", ODOM_TYPE: "--odom-topic", TEMPERATURE_TYPE: "--temperature-topic"}
EXAMPLE = {IMU_TYPE: "/imu/data", ODOM_TYPE: "/odom", TEMPERATURE_TYPE: "/imu/temperature"}

REPAIR_HINT = (
    "The file is not a bag this tool can read, or is damaged beyond its complete records: re-record it "
    "(`rosbag reindex` / `ros2 bag reindex` rebuild a missing index, not data cut short)"
)



def describe(path: Path) -> str:
    if path.is_dir():
        return f"rosbag2 directory {str(path)!r}"
    kind = {".bag": "ROS 1 bag", ".mcap": "rosbag2 mcap file", ".db3": "rosbag2 sqlite3 file"}.get(path.suffix, "bag")
    return f"{kind} {str(path)!r}"


@contextmanager
def open_bag(path: str | Path) -> Iterator[Any]:
    """An open AnyReader, with every failure turned into a BagError."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    bag = Path(path).expanduser()
    if not bag.exists():
        raise BagError(
            f"bag {str(bag)!r} does not exist: give a ROS 1 .bag file, a rosbag2 directory (with metadata.yaml) "
            "or a rosbag2 .db3/.mcap file"
        )
    if bag.is_file() and bag.suffix not in BAG_SUFFIXES:
        raise BagError(
            f"{str(bag)!r} is not a bag: expected a ROS 1 .bag file, a rosbag2 directory or a .db3/.mcap file"
        )
    if bag.is_file() and bag.stat().st_size == 0:
        raise BagError(f"{describe(bag)} is empty (0 bytes): re-record it")
    reader: Any = _salvaged(bag, None) if _has_wal(bag) else None
    if reader is None:
        try:
            reader = AnyReader([bag], default_typestore=get_typestore(Stores.LATEST))
            reader.open()
        except Exception as exc:
            reader = _salvaged(bag, exc)
    try:
        yield reader
    finally:
        with suppress(Exception):
            reader.close()


def _has_wal(bag: Path) -> bool:
    """Whether a sqlite3 bag has a write-ahead log with frames beside it."""
    files = [bag] if bag.is_file() else sorted(bag.glob("*.db3")) if bag.is_dir() else []
    return any(f.suffix == ".db3" and (w := f.with_name(f.name + "-wal")).is_file() and w.stat().st_size > 32
               for f in files)


def _salvaged(bag: Path, error: Exception | None) -> Any:
    """The complete messages of a bag rosbags cannot open (:mod:`.salvage`), or a BagError naming ``error``."""
    from .salvage import salvage

    why = f"cannot open {describe(bag)}: {reason(error)}. " if error is not None else f"{describe(bag)}: "
    try:
        reader = salvage(bag)
    except BagError as exc:
        raise BagError(f"{why}{exc}") from None
    except Exception as exc:  # a file too damaged to scan: the original reason is the message
        raise BagError(f"{why}{type(exc).__name__} while salvaging. {REPAIR_HINT}") from None
    if reader is None:
        raise BagError(f"{why}{REPAIR_HINT}")
    return reader


def reason(exc: BaseException) -> str:
    text = str(exc).strip().rstrip(".") or type(exc).__name__
    return text if len(text) < 300 else text[:300] + "…"


def topic_counts(reader: Any) -> dict[str, tuple[str, int]]:
    return {name: (info.msgtype or "(mixed types)", int(info.msgcount)) for name, info in reader.topics.items()}


def list_topics(path: str | Path) -> dict[str, tuple[str, int]]:
    """Topic → (message type, message count) of a bag, e.g. ``{'/imu/data': ('sensor_msgs/msg/Imu', 720000)}``."""
    with open_bag(path) as reader:
        return topic_counts(reader)


def listing(topics: Mapping[str, tuple[str, int]], msgtype: str | None = None) -> str:
    rows = [f"{name} ({typ}, {count} msgs)" for name, (typ, count) in topics.items() if msgtype in (None, typ)]
    return ", ".join(rows) if rows else "none"


def select_topic(
    topics: Mapping[str, tuple[str, int]],
    msgtype: str,
    topic: str | None,
    where: str,
    *,
    required: bool,
    notes: list[str],
) -> str | None:
    """The topic to read for ``msgtype`` (explicit, or the only one of that type), or None when optional."""
    what, flag = WHAT[msgtype], FLAG[msgtype]
    if topic is not None:
        if topic not in topics:
            raise BagError(
                f"topic {topic!r} is not in {where}. {what} topics there: {listing(topics, msgtype)}; "
                f"all topics: {listing(topics)}. Pass {flag} with one of them"
            )
        if topics[topic][0] != msgtype:
            raise BagError(
                f"topic {topic!r} in {where} has type {topics[topic][0]}, not {msgtype}. {what} topics there: "
                f"{listing(topics, msgtype)}. Pass {flag} with one of them"
            )
        return topic
    candidates = [name for name, (typ, _) in topics.items() if typ == msgtype]
    if len(candidates) == 1:
        return candidates[0]
    if len(candidates) > 1:
        if required:
            raise BagError(
                f"{where} has {len(candidates)} {what} topics: {listing(topics, msgtype)}. Pass {flag} to choose one"
            )
        notes.append(f"several {what} topics ({', '.join(candidates)}): none read; pass {flag} to choose one")
        return None
    if required:
        raise BagError(
            f"no {msgtype} topic in {where}; its topics are: {listing(topics)}. "
            f"Record the {what} topic (e.g. {EXAMPLE[msgtype]}) or read another bag"
        )
    return None
