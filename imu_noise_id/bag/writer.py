"""Write IMU (and optionally odometry and temperature) series into a rosbag2 bag (mcap or sqlite3), serialised to
little-endian CDR with numpy (:func:`encode_cdr`, equal to rosbags' ``serialize_cdr``)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..core.axes import ImuSeries, OdometrySeries, ScalarSeries
from ..core.simulation.robot import RobotRun
from .errors import BagError
from .fastdecode import PRIMITIVES, flatten
from .topics import IMU_TYPE, ODOM_TYPE, TEMPERATURE_TYPE

#: Messages serialised at a time (bounded memory for long series).
CHUNK = 65536

#: REP-145: element 0 of a covariance = -1 means "this field is not provided" (no orientation is written).
ORIENTATION_NOT_PROVIDED = -1.0


def _typestore() -> object:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


def stamps_to_ns(t: np.ndarray) -> np.ndarray:
    """Times [s] → integer nanoseconds (rounded); BagError for NaN/inf or negative times."""
    t = np.asarray(t, dtype=float)
    if not np.all(np.isfinite(t)) or np.any(t < 0) or np.any(t >= 2**31):
        raise BagError("stamps to write must be finite, >= 0 and before 2038 (int32 seconds)")
    sec = np.floor(t)
    nsec = np.rint((t - sec) * 1e9).astype(np.int64)
    return sec.astype(np.int64) * 1_000_000_000 + nsec


def encode_cdr(
    fielddefs: Mapping[str, tuple],
    msgtype: str,
    values: Mapping[str, np.ndarray],
    strings: Mapping[str, str],
) -> tuple[np.ndarray, int]:
    """Serialise ``n`` flat messages to little-endian CDR: (n, length) uint8 rows and the length. ``values``: leaf
    path → (n,) or (n, count) array (missing: 0); ``strings``: string leaf → its value in every message (missing: "").
    """
    leaves = flatten(fielddefs, msgtype)
    n = next(iter(values.values())).shape[0]
    encoded = {leaf.path: strings.get(leaf.path, "").encode() for leaf in leaves if leaf.kind == "string"}
    offsets: list[int] = []
    pos = 4
    for leaf in leaves:
        size = 4 if leaf.kind == "string" else PRIMITIVES[leaf.kind][1]
        pos = 4 + (pos - 4 + size - 1) // size * size
        offsets.append(pos)
        pos += 4 + len(encoded[leaf.path]) + 1 if leaf.kind == "string" else size * leaf.count
    length = pos
    buf = np.zeros((n, length), dtype=np.uint8)
    buf[:, 1] = 1  # encapsulation header 00 01 00 00: CDR, little endian
    for leaf, off in zip(leaves, offsets, strict=True):
        if leaf.kind == "string":
            text = encoded[leaf.path]
            buf[:, off : off + 4] = np.frombuffer(np.uint32(len(text) + 1).astype("<u4").tobytes(), np.uint8)
            buf[:, off + 4 : off + 4 + len(text)] = np.frombuffer(text, np.uint8)
        elif leaf.path in values:
            kind, size = PRIMITIVES[leaf.kind]
            view = buf[:, off : off + size * leaf.count].view(f"<{kind}")
            view[:] = np.asarray(values[leaf.path]).reshape(n, leaf.count)
    return buf, length


def _stamp_values(stamp_ns: np.ndarray) -> dict[str, np.ndarray]:
    return {"header.stamp.sec": stamp_ns // 1_000_000_000, "header.stamp.nanosec": stamp_ns % 1_000_000_000}


def _imu_values(imu: ImuSeries, rows: slice, stamp_ns: np.ndarray) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    n = stamp_ns.shape[0]
    values = {
        **_stamp_values(stamp_ns),
        "orientation.w": np.ones(n),
        "orientation_covariance": np.tile([ORIENTATION_NOT_PROVIDED, *[0.0] * 8], (n, 1)),
    }
    if imu.orientation_xyzw is not None:  # rows with NaN stay "not provided"
        q = imu.orientation_xyzw[rows]
        provided = np.isfinite(q).all(axis=1)
        for i, c in enumerate("xyzw"):
            values[f"orientation.{c}"] = np.where(provided, q[:, i], 1.0 if c == "w" else 0.0)
        values["orientation_covariance"][provided, 0] = 0.0  # provided, covariance unknown (REP-145)
    for i, c in enumerate("xyz"):
        values[f"angular_velocity.{c}"] = imu.gyro[rows, i]
        values[f"linear_acceleration.{c}"] = imu.accel[rows, i]
    return values, {"header.frame_id": imu.frame_id}


def _odom_values(
    odom: OdometrySeries, rows: slice, stamp_ns: np.ndarray
) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    values = {**_stamp_values(stamp_ns)}
    for i, c in enumerate("xyz"):
        values[f"pose.pose.position.{c}"] = np.asarray(odom.position)[rows, i]
        values[f"twist.twist.linear.{c}"] = np.asarray(odom.linear_velocity)[rows, i]
        values[f"twist.twist.angular.{c}"] = np.asarray(odom.angular_velocity)[rows, i]
    for i, c in enumerate("xyzw"):
        values[f"pose.pose.orientation.{c}"] = np.asarray(odom.orientation_xyzw)[rows, i]
    values["pose.covariance"] = np.asarray(odom.pose_covariance)[rows].reshape(-1, 36)
    values["twist.covariance"] = np.asarray(odom.twist_covariance)[rows].reshape(-1, 36)
    return values, {"header.frame_id": odom.frame_id, "child_frame_id": odom.child_frame_id}


def _temperature_values(
    temp: ScalarSeries, rows: slice, stamp_ns: np.ndarray
) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    return {**_stamp_values(stamp_ns), "temperature": np.asarray(temp.value)[rows]}, {"header.frame_id": ""}


def write_bag(
    path: str | Path,
    imu: ImuSeries,
    odom: OdometrySeries | None = None,
    temperature: ScalarSeries | None = None,
    *,
    storage: str = "mcap",
    imu_topic: str = "/imu/data",
    odom_topic: str = "/odom",
    temperature_topic: str = "/imu/temperature",
    receive_t: np.ndarray | None = None,
) -> Path:
    """Write a rosbag2 bag (directory ``path`` with ``metadata.yaml``, must not exist) holding the series; returns it.

    Parameters
    ----------
    imu, odom, temperature : series; their ``t`` become the header stamps (rounded to 1 ns)
    storage : ``"mcap"`` or ``"sqlite3"``
    imu_topic, odom_topic, temperature_topic : topic names
    receive_t : the IMU messages' receive times [s]; default the running maximum of ``imu.t``

    Raises
    ------
    BagError
        If ``path`` exists, ``storage`` is unknown, or stamps are negative or not finite.
    """
    from rosbags.rosbag2 import StoragePlugin, Writer, WriterError

    plugins = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}
    if storage not in plugins:
        raise BagError(f"unknown bag storage {storage!r}: use mcap or sqlite3")
    bag = Path(path)
    if bag.exists():
        raise BagError(f"output {str(bag)!r} exists already: choose another path or delete it")
    typestore = _typestore()
    streams = [(imu_topic, IMU_TYPE, imu, _imu_values)]
    if odom is not None:
        streams.append((odom_topic, ODOM_TYPE, odom, _odom_values))
    if temperature is not None:
        streams.append((temperature_topic, TEMPERATURE_TYPE, temperature, _temperature_values))
    stamps = [stamps_to_ns(series.t) for _, _, series, _ in streams]
    receive = [np.maximum.accumulate(s) if s.size else s for s in stamps]
    if receive_t is not None:
        receive[0] = stamps_to_ns(receive_t)
        if receive[0].shape != stamps[0].shape:
            raise BagError("receive_t must have one time per IMU sample")
    try:
        writer = Writer(bag, version=9, storage_plugin=plugins[storage])
        writer.open()
    except (WriterError, OSError) as exc:
        raise BagError(f"cannot create bag {str(bag)!r}: {exc}") from None
    try:
        connections = [writer.add_connection(topic, msgtype, typestore=typestore) for topic, msgtype, _, _ in streams]
        _write_merged(
            writer, typestore.fielddefs, streams=streams, connections=connections, stamps=stamps, receive=receive
        )
    finally:
        writer.close()
    return bag


def _write_merged(
    writer: Any,
    fielddefs: Mapping[str, tuple],
    *,
    streams: list[tuple[str, str, Any, Callable[..., tuple[dict[str, np.ndarray], dict[str, str]]]]],
    connections: list[Any],
    stamps: list[np.ndarray],
    receive: list[np.ndarray],
) -> None:
    """Write the streams interleaved in receive-time order, serialising CHUNK messages of a stream at a time."""
    labels = np.concatenate([np.full(r.shape[0], k, dtype=np.int8) for k, r in enumerate(receive)])
    order = np.argsort(np.concatenate(receive), kind="stable")
    kinds = labels[order]
    cursor = [0] * len(streams)
    cache: list[tuple[int, memoryview, int] | None] = [None] * len(streams)  # (first row, bytes, length)
    receive_lists = [r.tolist() for r in receive]
    for k in kinds.tolist():
        row = cursor[k]
        block = cache[k]
        if block is None or row >= block[0] + CHUNK:
            _, msgtype, series, values_of = streams[k]
            rows = slice(row, min(row + CHUNK, stamps[k].shape[0]))
            values, strings = values_of(series, rows, stamps[k][rows])
            buf, length = encode_cdr(fielddefs, msgtype, values, strings)
            block = cache[k] = (row, memoryview(buf.tobytes()), length)
        first, data, length = block
        i = row - first
        writer.write(connections[k], receive_lists[k][row], data[i * length : (i + 1) * length])
        cursor[k] = row + 1


def write_robot_bag(run: RobotRun, path: Path, imu_topic: str = "/imu/data", odom_topic: str = "/odom") -> Path:
    """Write a :class:`RobotRun` as a rosbag2 (mcap) bag with sensor_msgs/Imu and nav_msgs/Odometry."""
    imu = ImuSeries(t=run.imu_t, gyro=run.gyro, accel=run.accel, frame_id="imu_link", topic=imu_topic)
    odom = OdometrySeries(
        t=run.odom_t, position=run.position, orientation_xyzw=run.orientation_xyzw,
        linear_velocity=run.linear_velocity, angular_velocity=run.angular_velocity,
        pose_covariance=run.pose_cov, twist_covariance=run.twist_cov, frame_id="odom",
        child_frame_id="base_link", topic=odom_topic,
    )
    return write_bag(path, imu, odom, imu_topic=imu_topic, odom_topic=odom_topic)
