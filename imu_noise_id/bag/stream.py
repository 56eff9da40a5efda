"""Streaming decode of the chosen topics in one pass: batches of :data:`BATCH` raw messages decoded by
:mod:`.fastdecode` into arrays preallocated from the message counts, then repaired with a note per repair."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import replace
from itertools import islice
from pathlib import Path
from typing import Any

import numpy as np

from ..core.quality import IMU_MAX_ABS, QualityError, repair_time_series
from ..core.timing import SamplePeriod
from .errors import BagError
from .fastdecode import FlatDecoder
from .mcapfast import fast_mcap_batches
from .topics import (
    IMU_TYPE,
    ODOM_TYPE,
    REPAIR_HINT,
    TEMPERATURE_TYPE,
    describe,
    listing,
    open_bag,
    reason,
    select_topic,
    topic_counts,
)

#: Raw messages read and decoded at a time (about 5 MB of Imu messages).
BATCH = 16384

Progress = Callable[[int, int], None]

_STAMP = {"sec": ("header.stamp.sec",), "nsec": ("header.stamp.nanosec",)}


#: ``before_decoding(msgtype, topic, message count, bag span [s] or None)``: see :func:`read_topics`.
BeforeDecoding = Callable[[str, str, int, float | None], None]


def _xyz(prefix: str, names: str = "xyz") -> tuple[str, ...]:
    return tuple(f"{prefix}.{c}" for c in names)


_OUTPUTS: dict[str, dict[str, tuple[str, ...]]] = {
    IMU_TYPE: {
        **_STAMP,
        "gyro": _xyz("angular_velocity"),
        "accel": _xyz("linear_acceleration"),
        "orientation_xyzw": _xyz("orientation", "xyzw"),
        "orientation_cov0": ("orientation_covariance[0]",),
    },
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
#: Outputs decoded into per-batch temporaries for :meth:`TopicStream.add` (covariance flag not kept; orientation
#: allocated at the first batch that provides one).
_TRANSIENT: dict[str, frozenset[str]] = {IMU_TYPE: frozenset({"orientation_cov0", "orientation_xyzw"})}
#: Largest plausible magnitude per output (None: no limit), see repair_time_series.
_MAX_ABS = {"gyro": IMU_MAX_ABS[0], "accel": IMU_MAX_ABS[1]}

class TopicStream:
    """Arrays of one topic, preallocated from the message count and filled batch by batch."""

    def __init__(self, reader: Any, msgtype: str, topic: str, count: int, fast: bool) -> None:
        from rosbags.typesys import Stores, get_typestore

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
        # A bag whose definition is not flat still has the standard field sizes (e.g. 36 covariance values).
        reference = get_typestore(Stores.LATEST).fielddefs if self.decoder.leaves is None else None
        self.widths = {k: w for k, w in self.decoder.widths(reference).items() if k not in _STAMP}
        transient = _TRANSIENT.get(msgtype, frozenset())
        self.transient = {k: w for k, w in self.widths.items() if k in transient}
        self.widths = {k: w for k, w in self.widths.items() if k not in transient}
        self.expected = count
        self.capacity = max(count, 1)
        self.n = 0
        self.first_raw: bytes | None = None
        self.declared_covariance: dict[str, np.ndarray] = {}
        self.period: SamplePeriod | None = None
        self.t = np.empty(self.capacity)
        # Receive times [s]: the stamps when every header stamp is zero, else a second clock for the period.
        self.receive = np.empty(self.capacity)
        self.stamped = False
        self.arrays = {k: np.empty((self.capacity, w) if w > 1 else self.capacity) for k, w in self.widths.items()}

    def _grow(self, need: int) -> None:
        self.capacity = max(need, int(self.capacity * 1.5))
        self.t = np.resize(self.t, self.capacity)
        self.receive = np.resize(self.receive, self.capacity)
        self.arrays = {k: np.resize(a, (self.capacity, *a.shape[1:])) for k, a in self.arrays.items()}

    def add(self, raws: list[bytes], receive_ns: list[int]) -> None:
        k = len(raws)
        if self.first_raw is None and raws:
            self.first_raw = raws[0]
        if self.n + k > self.capacity:
            self._grow(self.n + k)
        s, e = self.n, self.n + k
        sec = np.empty(k, dtype=np.int64)
        nsec = np.empty(k, dtype=np.int64)
        views = {name: a[s:e] for name, a in self.arrays.items()}
        transient = {name: np.empty((k, w) if w > 1 else k) for name, w in self.transient.items()}
        self.decoder.decode(raws, {"sec": sec, "nsec": nsec, **views, **transient})
        if "orientation_xyzw" in transient:
            self._keep_orientation(s, e, transient["orientation_xyzw"], transient["orientation_cov0"])
        self.t[s:e] = sec + nsec * 1e-9
        self.stamped = self.stamped or bool(np.any(sec) or np.any(nsec))
        self.receive[s:e] = np.asarray(receive_ns, dtype=np.int64) * 1e-9
        self.n = e

    def _keep_orientation(self, s: int, e: int, q: np.ndarray, cov0: np.ndarray) -> None:
        """Store rows ``s:e`` of the orientation, allocating its array at the first batch that provides one."""
        _mark_orientation_not_provided(q, cov0)
        kept = self.arrays.get("orientation_xyzw")
        if kept is None and q.any():
            kept = self.arrays["orientation_xyzw"] = np.zeros((self.capacity, 4))  # earlier rows: not provided
        if kept is not None:
            kept[s:e] = q

    def trimmed(self) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        n = self.n
        return self.t[:n], self.receive[:n], {k: a[:n] for k, a in self.arrays.items()}


def _mark_orientation_not_provided(q: np.ndarray, cov0: np.ndarray) -> None:
    """Zero the orientation rows not provided (REP-145: ``orientation_covariance[0] == -1``) or unusable (NaN/inf, zero
    quaternion); :func:`_imu` turns the zero marker into NaN rows after the repair."""
    bad = (cov0 == -1.0) | ~np.isfinite(q).all(axis=1)
    if bad.any():
        q[bad] = 0.0


def finish(stream: TopicStream, where: str, notes: list[str], declared_hz: float | None = None,
           salvage_note: str | None = None) -> tuple[np.ndarray, dict[str, np.ndarray], list[str]]:
    """Stamps, arrays and notes of a stream after the repairs; the period (stamps, positions, receive times, or
    ``declared_hz``) is left in ``stream.period``; ``salvage_note`` becomes the first note."""
    topic_notes: list[str] = [salvage_note] if salvage_note else []
    if stream.msgtype == IMU_TYPE and stream.first_raw is not None:
        first = stream.decoder.deserialize(stream.first_raw, IMU_TYPE)
        stream.declared_covariance = {
            name: np.asarray(getattr(first, f"{name}_covariance"), dtype=float).reshape(3, 3)
            for name in ("orientation", "angular_velocity", "linear_acceleration")
        }
    t, receive, arrays = stream.trimmed()
    if stream.n == 0:
        raise BagError(
            f"topic {stream.topic!r} in {where} has no readable messages (the index announced {stream.expected}). "
            f"{REPAIR_HINT}"
        )
    if stream.n != stream.expected:
        topic_notes.append(f"the bag index announced {stream.expected} messages but {stream.n} were read")
    if not stream.stamped:  # every header stamp is zero
        t, receive = receive, None
        topic_notes.append(
            "every header stamp is zero (the publisher does not set header.stamp): using the bag's receive times, "
            "which include transport delays and jitter"
        )
    for path in sorted(stream.decoder.varying_strings):
        value = stream.decoder.strings.get(path, "")
        topic_notes.append(f"{path} changes between messages; the first value {value!r} is reported")
    names = list(arrays)
    try:
        limits = [_MAX_ABS.get(k) for k in names] if stream.msgtype == IMU_TYPE else None
        t, columns, report = repair_time_series(t, [arrays[k] for k in names], max_abs=limits, receive=receive,
                                                declared_hz=declared_hz)
    except QualityError as exc:
        raise BagError(f"topic {stream.topic!r} in {where}: {exc}. Check the sensor driver or record again") from None
    stream.period = report.period
    if report.period.refusal is not None:
        stream.period = replace(report.period, refusal=f"topic {stream.topic!r} in {where}: {report.period.refusal}")
    topic_notes.extend(report.notes("messages"))
    notes.extend(f"{stream.topic}: {note}" for note in topic_notes)
    return t, dict(zip(names, columns, strict=True)), topic_notes


def read_topics(
    path: str | Path,
    wanted: dict[str, tuple[str | None, bool]],
    progress: Progress | None,
    fast: bool,
    rate_hz: float | None = None,
    *,
    before_decoding: BeforeDecoding | None = None,
) -> tuple[Path, dict[str, tuple[np.ndarray, dict[str, np.ndarray], list[str], TopicStream]], list[str]]:
    """Read the topics of the types in ``wanted`` (msgtype → (topic or None, required)) in one pass; ``rate_hz`` the
    IMU's declared rate; an unusable optional topic is left out with a note. ``before_decoding(msgtype, topic, count,
    span_s)`` is called for each topic read, with its message count and the bag's time span [s] (None where the
    reader has none), before anything is decoded or allocated: it may refuse the bag by raising."""
    bag = Path(path).expanduser()
    notes: list[str] = []
    with open_bag(bag) as reader:
        where = describe(bag)
        topics = topic_counts(reader)
        if not topics or not any(count for _, count in topics.values()):
            raise BagError(f"{where} contains no messages (topics: {listing(topics)}): record data into it first")
        streams: dict[str, TopicStream] = {}
        by_connection: dict[int, TopicStream] = {}
        for msgtype, (topic, required) in wanted.items():
            name = select_topic(topics, msgtype, topic, where, required=required, notes=notes)
            if name is None:
                continue
            count = topics[name][1]
            if count == 0:
                if required:
                    raise BagError(f"topic {name!r} in {where} has no messages: record it, or choose another topic")
                notes.append(f"{name}: no messages")
                continue
            if before_decoding is not None:
                duration_ns = getattr(reader, "duration", None)
                before_decoding(msgtype, name, count, None if not duration_ns else duration_ns * 1e-9)
            stream = TopicStream(reader, msgtype, name, count, fast)
            streams[msgtype] = stream
            for connection in reader.topics[name].connections:
                by_connection[id(connection)] = stream
        connections = [c for c in reader.connections if id(c) in by_connection]
        total = sum(s.expected for s in streams.values())
        done = 0
        try:
            single = next(iter(streams.values())) if len(streams) == 1 else None
            for batch in _batches(reader, connections):
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
                f"{where} is truncated or corrupt: reading failed with {done} of {total} messages decoded "
                f"({type(exc).__name__}: {reason(exc)}). {REPAIR_HINT}"
            ) from None
        results = {}
        for msgtype, stream in streams.items():
            try:
                t, arrays, topic_notes = finish(stream, where, notes, rate_hz if msgtype == IMU_TYPE else None,
                                                getattr(reader, "note", None))
            except BagError as exc:
                if wanted[msgtype][1]:
                    raise
                notes.append(f"{stream.topic}: not used ({exc})")  # an optional topic: the rest is still usable
                continue
            results[msgtype] = (t, arrays, topic_notes, stream)
    return bag, results, notes


def _batches(reader: Any, connections: list[Any]) -> Iterator[list[tuple[Any, int, bytes]]]:
    """Lists of about BATCH (connection, receive time [ns], raw bytes), in the order rosbags yields them."""
    chunks = fast_mcap_batches(reader, connections)
    if chunks is None:
        messages = reader.messages(connections=connections)
        while batch := list(islice(messages, BATCH)):
            yield batch
        return
    pending: list[tuple[Any, int, bytes]] = []
    for chunk in chunks:
        pending.extend(chunk)
        if len(pending) >= BATCH:
            yield pending
            pending = []
    if pending:
        yield pending


def _dispatch(batch: list[tuple[Any, int, bytes]], by_connection: dict[int, TopicStream]) -> None:
    parts: dict[int, tuple[TopicStream, list[bytes], list[int]]] = {}
    for connection, receive, raw in batch:
        stream = by_connection[id(connection)]
        entry = parts.setdefault(id(stream), (stream, [], []))
        entry[1].append(raw)
        entry[2].append(receive)
    for stream, raws, receive in parts.values():
        stream.add(raws, receive)
