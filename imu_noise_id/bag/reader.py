"""Read IMU, odometry and temperature series from ROS 1 ``.bag``, rosbag2 sqlite3 and rosbag2 mcap bags.

No ROS install is needed: :class:`rosbags.highlevel.AnyReader` reads the files and the message definitions stored
in them. Values come out as numpy arrays in the dataclasses of :mod:`imu_noise_id.core.axes`, timed by the
messages' header stamps (``sec + nanosec·1e-9`` seconds).

Speed and memory: messages are read in batches of :data:`BATCH` raw messages, decoded with numpy at fixed byte
offsets (:mod:`.fastdecode`, identical to full deserialisation, which remains the fallback) and written into
arrays preallocated from the bag's message counts, so no message objects are kept.

Every problem with the input raises :class:`~.errors.BagError` naming the bag, the topic and what to do, or is
repaired by :func:`imu_noise_id.core.quality.repair_time_series` with a note in the result (see ``docs/bags.md``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field
from itertools import islice
from pathlib import Path
from typing import Any

import numpy as np

from ..core.axes import ImuSeries, OdometrySeries, ScalarSeries
from ..core.quality import IMU_MAX_ABS, QualityError, repair_time_series
from .errors import BagError
from .fastdecode import FlatDecoder

IMU_TYPE = "sensor_msgs/msg/Imu"
ODOM_TYPE = "nav_msgs/msg/Odometry"
TEMPERATURE_TYPE = "sensor_msgs/msg/Temperature"

#: Raw messages read and decoded at a time (about 5 MB of Imu messages).
BATCH = 16384

Progress = Callable[[int, int], None]

_STAMP = {"sec": ("header.stamp.sec",), "nsec": ("header.stamp.nanosec",)}


def _xyz(prefix: str, names: str = "xyz") -> tuple[str, ...]:
    return tuple(f"{prefix}.{c}" for c in names)


_OUTPUTS: dict[str, dict[str, tuple[str, ...]]] = {
    IMU_TYPE: {**_STAMP, "gyro": _xyz("angular_velocity"), "accel": _xyz("linear_acceleration")},
    ODOM_TYPE: {
        **_STAMP,
        "position": _xyz("pose.pose.position"),
        "orientation_xyzw": _xyz("pose.pose.orientation", "xyzw"),
        "linear_velocity": _xyz("twist.twist.linear"),
        "angular_velocity": _xyz("twist.twist.angular"),
        "pose_covariance": ("pose.covariance",),
        "twist_covariance": ("twist.covariance",),
    },
    TEMPERATURE_TYPE: {**_STAMP, "value": ("temperature",)},
}
_STRINGS: dict[str, tuple[str, ...]] = {
    IMU_TYPE: ("header.frame_id",),
    ODOM_TYPE: ("header.frame_id", "child_frame_id"),
    TEMPERATURE_TYPE: (),
}
_WHAT = {IMU_TYPE: "Imu", ODOM_TYPE: "Odometry", TEMPERATURE_TYPE: "Temperature"}
_FLAG = {IMU_TYPE: "--topic", ODOM_TYPE: "--odom-topic", TEMPERATURE_TYPE: "--temperature-topic"}

_REPAIR_HINT = (
    "The file is empty, truncated or corrupt (e.g. the recorder was killed): re-record it, or repair it with "
    "`rosbag reindex` (ROS 1) / `ros2 bag reindex` (rosbag2) and try again"
)


@dataclass
class BagContents:
    """What :func:`read_bag` read in one pass.

    Attributes
    ----------
    path : the bag
    imu : the IMU series (repaired; its ``notes`` list the repairs)
    odom : odometry, or None when the bag has none (or several and none was chosen)
    temperature : temperature [°C], or None when absent
    notes : every note about the bag and its topics (including the IMU's)
    decode_stats : topic → (messages decoded by numpy, messages fully deserialised)
    """

    path: Path
    imu: ImuSeries
    odom: OdometrySeries | None = None
    temperature: ScalarSeries | None = None
    notes: list[str] = field(default_factory=list)
    decode_stats: dict[str, tuple[int, int]] = field(default_factory=dict)


# --- opening ----------------------------------------------------------------------------------------------------


def _describe(path: Path) -> str:
    if path.is_dir():
        return f"rosbag2 directory {str(path)!r}"
    kind = {".bag": "ROS 1 bag", ".mcap": "rosbag2 mcap file", ".db3": "rosbag2 sqlite3 file"}.get(path.suffix, "bag")
    return f"{kind} {str(path)!r}"


@contextmanager
def _open(path: str | Path) -> Iterator[Any]:
    """An open AnyReader, with every failure turned into a BagError."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    bag = Path(path)
    if not bag.exists():
        raise BagError(
            f"bag {str(bag)!r} does not exist: give a ROS 1 .bag file, a rosbag2 directory (with metadata.yaml) "
            "or a rosbag2 .db3/.mcap file"
        )
    if bag.is_file() and bag.suffix not in (".bag", ".db3", ".mcap"):
        raise BagError(
            f"{str(bag)!r} is not a bag: expected a ROS 1 .bag file, a rosbag2 directory or a .db3/.mcap file"
        )
    if bag.is_file() and bag.stat().st_size == 0:
        raise BagError(f"{_describe(bag)} is empty (0 bytes): re-record it")
    try:
        reader = AnyReader([bag], default_typestore=get_typestore(Stores.LATEST))
        reader.open()
    except Exception as exc:
        raise BagError(f"cannot open {_describe(bag)}: {_reason(exc)}. {_REPAIR_HINT}") from None
    try:
        yield reader
    finally:
        with suppress(Exception):
            reader.close()


def _reason(exc: BaseException) -> str:
    text = str(exc).strip().rstrip(".") or type(exc).__name__
    return text if len(text) < 300 else text[:300] + "…"


def _topics(reader: Any) -> dict[str, tuple[str, int]]:
    return {name: (info.msgtype or "(mixed types)", int(info.msgcount)) for name, info in reader.topics.items()}


def list_topics(path: str | Path) -> dict[str, tuple[str, int]]:
    """Topic → (message type, message count) of a bag, e.g. ``{'/imu/data': ('sensor_msgs/msg/Imu', 720000)}``."""
    with _open(path) as reader:
        return _topics(reader)


def _listing(topics: Mapping[str, tuple[str, int]], msgtype: str | None = None) -> str:
    rows = [f"{name} ({typ}, {count} msgs)" for name, (typ, count) in topics.items() if msgtype in (None, typ)]
    return ", ".join(rows) if rows else "none"


def _select(
    topics: Mapping[str, tuple[str, int]],
    msgtype: str,
    topic: str | None,
    where: str,
    *,
    required: bool,
    notes: list[str],
) -> str | None:
    """The topic to read for ``msgtype`` (explicit, or the only one of that type), or None when optional."""
    what, flag = _WHAT[msgtype], _FLAG[msgtype]
    if topic is not None:
        if topic not in topics:
            raise BagError(
                f"topic {topic!r} is not in {where}. {what} topics there: {_listing(topics, msgtype)}; "
                f"all topics: {_listing(topics)}. Pass {flag} with one of them"
            )
        if topics[topic][0] != msgtype:
            raise BagError(
                f"topic {topic!r} in {where} has type {topics[topic][0]}, not {msgtype}. {what} topics there: "
                f"{_listing(topics, msgtype)}. Pass {flag} with one of them"
            )
        return topic
    candidates = [name for name, (typ, _) in topics.items() if typ == msgtype]
    if len(candidates) == 1:
        return candidates[0]
    if len(candidates) > 1:
        if required:
            raise BagError(
                f"{where} has {len(candidates)} {what} topics: {_listing(topics, msgtype)}. Pass {flag} to choose one"
            )
        notes.append(f"several {what} topics ({', '.join(candidates)}): none read; pass {flag} to choose one")
        return None
    if required:
        raise BagError(
            f"no {msgtype} topic in {where}; its topics are: {_listing(topics)}. "
            f"Record the {what} topic (e.g. /imu/data) or read another bag"
        )
    return None


# --- streaming decode -------------------------------------------------------------------------------------------


class _Stream:
    """Arrays of one topic, preallocated from the message count and filled batch by batch."""

    def __init__(self, reader: Any, msgtype: str, topic: str, count: int, fast: bool) -> None:
        self.msgtype = msgtype
        self.topic = topic
        self.decoder = FlatDecoder(
            reader.typestore.fielddefs,
            msgtype,
            _OUTPUTS[msgtype],
            strings=_STRINGS[msgtype],
            ros1=not reader.is2,
            deserialize=reader.deserialize,
            fast=fast,
        )
        self.widths = {k: w for k, w in self.decoder.widths().items() if k not in _STAMP}
        self.expected = count
        self.capacity = max(count, 1)
        self.n = 0
        self.t = np.empty(self.capacity)
        self.receive_ns = np.empty(self.capacity, dtype=np.int64)
        self.arrays = {k: np.empty((self.capacity, w) if w > 1 else self.capacity) for k, w in self.widths.items()}

    def _grow(self, need: int) -> None:
        self.capacity = max(need, int(self.capacity * 1.5))
        self.t = np.resize(self.t, self.capacity)
        self.receive_ns = np.resize(self.receive_ns, self.capacity)
        self.arrays = {k: np.resize(a, (self.capacity, *a.shape[1:])) for k, a in self.arrays.items()}

    def add(self, raws: list[bytes], receive_ns: list[int]) -> None:
        k = len(raws)
        if self.n + k > self.capacity:
            self._grow(self.n + k)
        s, e = self.n, self.n + k
        sec = np.empty(k, dtype=np.int64)
        nsec = np.empty(k, dtype=np.int64)
        views = {name: a[s:e] for name, a in self.arrays.items()}
        self.decoder.decode(raws, {"sec": sec, "nsec": nsec, **views})
        self.t[s:e] = sec + nsec * 1e-9
        self.receive_ns[s:e] = receive_ns
        self.n = e

    def trimmed(self) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        n = self.n
        return self.t[:n], self.receive_ns[:n], {k: a[:n] for k, a in self.arrays.items()}


def _finish(stream: _Stream, where: str, notes: list[str]) -> tuple[np.ndarray, dict[str, np.ndarray], list[str]]:
    """Stamps and arrays of a stream after the documented repairs, with the notes about it."""
    topic_notes: list[str] = []
    t, receive_ns, arrays = stream.trimmed()
    if stream.n == 0:
        raise BagError(
            f"topic {stream.topic!r} in {where} has no readable messages (the index announced {stream.expected}). "
            f"{_REPAIR_HINT}"
        )
    if stream.n != stream.expected:
        topic_notes.append(f"the bag index announced {stream.expected} messages but {stream.n} were read")
    if not np.any(t):
        t = receive_ns * 1e-9
        topic_notes.append(
            "every header stamp is zero (the publisher does not set header.stamp): using the bag's receive times, "
            "which include transport delays and jitter"
        )
    for path in sorted(stream.decoder.varying_strings):
        value = stream.decoder.strings.get(path, "")
        topic_notes.append(f"{path} changes between messages; the first value {value!r} is reported")
    names = list(arrays)
    try:
        limits = IMU_MAX_ABS if stream.msgtype == IMU_TYPE else None
        t, columns, report = repair_time_series(t, [arrays[k] for k in names], max_abs=limits)
    except QualityError as exc:
        raise BagError(f"topic {stream.topic!r} in {where}: {exc}. Check the sensor driver or record again") from None
    topic_notes.extend(report.notes("messages"))
    notes.extend(f"{stream.topic}: {note}" for note in topic_notes)
    return t, dict(zip(names, columns, strict=True)), topic_notes


def _read(
    path: str | Path,
    wanted: dict[str, tuple[str | None, bool]],
    progress: Progress | None,
    fast: bool,
) -> tuple[Path, dict[str, tuple[np.ndarray, dict[str, np.ndarray], list[str], _Stream]], list[str]]:
    """Read the topics of the message types in ``wanted`` (msgtype → (topic or None, required)) in one pass."""
    bag = Path(path)
    notes: list[str] = []
    with _open(bag) as reader:
        where = _describe(bag)
        topics = _topics(reader)
        if not topics or not any(count for _, count in topics.values()):
            raise BagError(f"{where} contains no messages (topics: {_listing(topics)}): record data into it first")
        streams: dict[str, _Stream] = {}
        by_connection: dict[int, _Stream] = {}
        for msgtype, (topic, required) in wanted.items():
            name = _select(topics, msgtype, topic, where, required=required, notes=notes)
            if name is None:
                continue
            count = topics[name][1]
            if count == 0:
                if required:
                    raise BagError(f"topic {name!r} in {where} has no messages: record it, or choose another topic")
                notes.append(f"{name}: no messages")
                continue
            stream = _Stream(reader, msgtype, name, count, fast)
            streams[msgtype] = stream
            for connection in reader.topics[name].connections:
                by_connection[id(connection)] = stream
        connections = [c for c in reader.connections if id(c) in by_connection]
        total = sum(s.expected for s in streams.values())
        done = 0
        try:
            messages = reader.messages(connections=connections)
            single = next(iter(streams.values())) if len(streams) == 1 else None
            while batch := list(islice(messages, BATCH)):
                if single is not None:
                    _, receive, raws = zip(*batch, strict=True)
                    single.add(list(raws), list(receive))
                else:
                    _dispatch(batch, by_connection)
                done += len(batch)
                if progress is not None:
                    progress(done, total)
        except BagError:
            raise
        except Exception as exc:
            raise BagError(
                f"{where} is truncated or corrupt: reading stopped after {done} of {total} messages "
                f"({type(exc).__name__}: {_reason(exc)}). {_REPAIR_HINT}"
            ) from None
        results = {}
        for msgtype, stream in streams.items():
            t, arrays, topic_notes = _finish(stream, where, notes)
            results[msgtype] = (t, arrays, topic_notes, stream)
    return bag, results, notes


def _dispatch(batch: list[tuple[Any, int, bytes]], by_connection: dict[int, _Stream]) -> None:
    parts: dict[int, tuple[_Stream, list[bytes], list[int]]] = {}
    for connection, receive, raw in batch:
        stream = by_connection[id(connection)]
        entry = parts.setdefault(id(stream), (stream, [], []))
        entry[1].append(raw)
        entry[2].append(receive)
    for stream, raws, receive in parts.values():
        stream.add(raws, receive)


# --- series -----------------------------------------------------------------------------------------------------


def _imu(entry: tuple[np.ndarray, dict[str, np.ndarray], list[str], _Stream]) -> ImuSeries:
    t, arrays, topic_notes, stream = entry
    frame = stream.decoder.strings.get("header.frame_id", "")
    return ImuSeries(t=t, gyro=arrays["gyro"], accel=arrays["accel"], frame_id=frame, topic=stream.topic,
                     notes=list(topic_notes))  # fmt: skip


def _odometry(entry: tuple[np.ndarray, dict[str, np.ndarray], list[str], _Stream]) -> OdometrySeries:
    t, arrays, _, stream = entry
    strings = stream.decoder.strings
    return OdometrySeries(
        t=t,
        position=arrays["position"],
        orientation_xyzw=arrays["orientation_xyzw"],
        linear_velocity=arrays["linear_velocity"],
        angular_velocity=arrays["angular_velocity"],
        pose_covariance=arrays["pose_covariance"].reshape(-1, 6, 6),
        twist_covariance=arrays["twist_covariance"].reshape(-1, 6, 6),
        frame_id=strings.get("header.frame_id", ""),
        child_frame_id=strings.get("child_frame_id", ""),
        topic=stream.topic,
    )


def _temperature(entry: tuple[np.ndarray, dict[str, np.ndarray], list[str], _Stream]) -> ScalarSeries:
    t, arrays, _, stream = entry
    return ScalarSeries(t=t, value=arrays["value"], topic=stream.topic)


def _stats(results: Mapping[str, tuple[Any, Any, Any, _Stream]]) -> dict[str, tuple[int, int]]:
    return {e[3].topic: (e[3].decoder.stats.fast, e[3].decoder.stats.fallback) for e in results.values()}


def read_bag(
    path: str | Path,
    imu_topic: str | None = None,
    odom_topic: str | None = None,
    temperature_topic: str | None = None,
    require_odometry: bool = False,
    *,
    progress: Progress | None = None,
    fast: bool = True,
) -> BagContents:
    """IMU, and where present odometry and temperature, of a bag in one pass.

    Parameters
    ----------
    path : ROS 1 ``.bag``, rosbag2 directory, or rosbag2 ``.db3`` / ``.mcap`` file
    imu_topic, odom_topic, temperature_topic : topics to read; None picks the only topic of the type. Odometry and
        temperature are optional: absent (or ambiguous, with a note) gives None.
    require_odometry : raise when no odometry topic can be read
    progress : called as ``progress(messages_read, messages_total)`` after every batch
    fast : False decodes every message with rosbags' full deserialiser (reference path, several times slower)

    Raises
    ------
    BagError
        Missing/empty/corrupt bag, no or several Imu topics without ``imu_topic``, wrong type, no usable sample.
    """
    wanted = {
        IMU_TYPE: (imu_topic, True),
        ODOM_TYPE: (odom_topic, require_odometry or odom_topic is not None),
        TEMPERATURE_TYPE: (temperature_topic, temperature_topic is not None),
    }
    bag, results, notes = _read(path, wanted, progress, fast)
    return BagContents(
        path=bag,
        imu=_imu(results[IMU_TYPE]),
        odom=_odometry(results[ODOM_TYPE]) if ODOM_TYPE in results else None,
        temperature=_temperature(results[TEMPERATURE_TYPE]) if TEMPERATURE_TYPE in results else None,
        notes=notes,
        decode_stats=_stats(results),
    )


def read_imu(path: str | Path, topic: str | None = None, progress: Progress | None = None) -> ImuSeries:
    """The sensor_msgs/Imu series of ``topic`` (or of the bag's only Imu topic); repairs are in ``.notes``."""
    _, results, _ = _read(path, {IMU_TYPE: (topic, True)}, progress, True)
    return _imu(results[IMU_TYPE])


def read_odometry(path: str | Path, topic: str | None = None) -> OdometrySeries:
    """The nav_msgs/Odometry series of ``topic`` (or of the bag's only Odometry topic)."""
    _, results, _ = _read(path, {ODOM_TYPE: (topic, True)}, None, True)
    return _odometry(results[ODOM_TYPE])


def read_temperature(path: str | Path, topic: str | None = None) -> ScalarSeries | None:
    """The sensor_msgs/Temperature series [°C] of ``topic``, of the only Temperature topic, or None if absent."""
    bag = Path(path)
    with _open(bag) as reader:
        topics = _topics(reader)
    if topic is None and not any(typ == TEMPERATURE_TYPE for typ, _ in topics.values()):
        return None
    _, results, _ = _read(bag, {TEMPERATURE_TYPE: (topic, True)}, None, True)
    return _temperature(results[TEMPERATURE_TYPE])
