"""Read IMU, odometry and temperature series from ROS 1 ``.bag``, rosbag2 sqlite3 and mcap bags into the
dataclasses of :mod:`imu_noise_id.core.axes`, timed by header stamps, in one pass (:mod:`.stream`, :mod:`.topics`).
Problems raise :class:`~.errors.BagError` or are repaired with a note (docs/bags.md)."""


from __future__ import annotations

import zipfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..core.axes import ImuSeries, OdometrySeries, ScalarSeries
from ..core.errors import InputError
from ..core.quality import IMU_MAX_ABS, repair_time_series
from .errors import BagError
from .stream import BeforeDecoding, Progress, TopicStream, read_topics
from .topics import IMU_TYPE, ODOM_TYPE, TEMPERATURE_TYPE, reason


@dataclass
class BagContents:
    """What :func:`read_bag` read in one pass.

    Attributes
    ----------
    path : the bag
    imu : the repaired IMU series (``notes``: the repairs)
    odom, temperature : odometry and temperature [°C], or None when absent (or ambiguous)
    notes : every note about the bag and its topics
    decode_stats : topic → (messages decoded by numpy, messages fully deserialised)
    imu_covariance : the first Imu message's ``orientation``, ``angular_velocity`` [(rad/s)²] and
        ``linear_acceleration`` [(m/s²)²] covariances, 3×3 row-major as published (REP-145)
    """

    path: Path
    imu: ImuSeries
    odom: OdometrySeries | None = None
    temperature: ScalarSeries | None = None
    notes: list[str] = field(default_factory=list)
    decode_stats: dict[str, tuple[int, int]] = field(default_factory=dict)
    imu_covariance: dict[str, np.ndarray] = field(default_factory=dict)


def _imu(entry: tuple[np.ndarray, dict[str, np.ndarray], list[str], TopicStream]) -> ImuSeries:
    t, arrays, topic_notes, stream = entry
    frame = stream.decoder.strings.get("header.frame_id", "")
    orientation = arrays.get("orientation_xyzw")
    if orientation is not None:
        provided = orientation.any(axis=1)  # zero rows: marked by _mark_orientation_not_provided (or published so)
        if not provided.any():
            orientation = None  # provided only in samples the repair dropped
        elif not provided.all():
            orientation[~provided] = np.nan  # in place: the stream's buffer is ours
    return ImuSeries(t=t, gyro=arrays["gyro"], accel=arrays["accel"], frame_id=frame, topic=stream.topic,
                     notes=list(topic_notes), orientation_xyzw=orientation, period=stream.period)  # fmt: skip


def _odometry(entry: tuple[np.ndarray, dict[str, np.ndarray], list[str], TopicStream]) -> OdometrySeries:
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


def _temperature(entry: tuple[np.ndarray, dict[str, np.ndarray], list[str], TopicStream]) -> ScalarSeries:
    t, arrays, _, stream = entry
    return ScalarSeries(t=t, value=arrays["value"], topic=stream.topic)


def _stats(results: Mapping[str, tuple[Any, Any, Any, TopicStream]]) -> dict[str, tuple[int, int]]:
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
    rate_hz: float | None = None,
) -> BagContents:
    """IMU, and where present odometry and temperature, of a bag in one pass.

    Parameters
    ----------
    path : ROS 1 ``.bag``, rosbag2 directory, or ``.db3`` / ``.mcap`` file
    imu_topic, odom_topic, temperature_topic : topics; None picks the only one of the type (odometry and
        temperature are optional)
    require_odometry : raise when no odometry topic can be read
    progress : ``progress(messages_read, messages_total)`` after every batch
    fast : False decodes every message with rosbags' full deserialiser (reference path)
    rate_hz : the IMU's declared rate (``--rate``); None: from the stamps

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
    bag, results, notes = read_topics(path, wanted, progress, fast, rate_hz)
    return BagContents(
        path=bag,
        imu=_imu(results[IMU_TYPE]),
        odom=_odometry(results[ODOM_TYPE]) if ODOM_TYPE in results else None,
        temperature=_temperature(results[TEMPERATURE_TYPE]) if TEMPERATURE_TYPE in results else None,
        notes=notes,
        decode_stats=_stats(results),
        imu_covariance=results[IMU_TYPE][3].declared_covariance,
    )


def read_imu(path: str | Path, topic: str | None = None, progress: Progress | None = None, *,
             rate_hz: float | None = None) -> ImuSeries:
    """The sensor_msgs/Imu series of ``topic`` (or the bag's only one; repairs in ``.notes``); ``path`` may be an
    ``.npz`` (:func:`read_static`); ``rate_hz`` as in :func:`read_bag`."""
    p = Path(path).expanduser()
    if p.suffix == ".npz":
        return read_npz(p, rate_hz)
    _, results, _ = read_topics(p, {IMU_TYPE: (topic, True)}, progress, True, rate_hz)
    return _imu(results[IMU_TYPE])


def read_odometry(path: str | Path, topic: str | None = None) -> OdometrySeries:
    """The nav_msgs/Odometry series of ``topic`` (or of the bag's only Odometry topic)."""
    _, results, _ = read_topics(path, {ODOM_TYPE: (topic, True)}, None, True)
    return _odometry(results[ODOM_TYPE])


def read_static(path: str | Path, topic: str | None = None, temperature_topic: str | None = None,
                progress: Progress | None = None, *, rate_hz: float | None = None,
                before_decoding: BeforeDecoding | None = None) -> BagContents:
    """What a static analysis reads in one pass: the IMU series and, where present, the temperature [°C]. ``path`` may
    be an ``.npz`` with ``t`` [s] (or ``fs_hz``), ``gyro`` [rad/s] (N, 3), ``accel`` [m/s²] (N, 3).
    ``before_decoding``: see :func:`~.stream.read_topics` (a bag only)."""
    p = Path(path).expanduser()
    if p.suffix == ".npz":
        imu = read_npz(p, rate_hz)
        return BagContents(path=p, imu=imu, notes=[f"{imu.topic}: {note}" for note in imu.notes])
    wanted = {IMU_TYPE: (topic, True), TEMPERATURE_TYPE: (temperature_topic, temperature_topic is not None)}
    bag, results, notes = read_topics(p, wanted, progress, True, rate_hz, before_decoding=before_decoding)
    return BagContents(
        path=bag, imu=_imu(results[IMU_TYPE]),
        temperature=_temperature(results[TEMPERATURE_TYPE]) if TEMPERATURE_TYPE in results else None,
        notes=notes, decode_stats=_stats(results), imu_covariance=results[IMU_TYPE][3].declared_covariance,
    )


def _npz_array(path: Path, data: Any, name: str, shape: str) -> np.ndarray:
    try:
        value = np.asarray(data[name], dtype=float)
    except (TypeError, ValueError) as exc:
        raise BagError(f"{str(path)!r}: array {name!r} is not numeric ({reason(exc)}); it must be {shape}") from None
    if (shape == "(N, 3)" and (value.ndim != 2 or value.shape[1] != 3)) or (shape == "(N,)" and value.ndim != 1):
        raise BagError(f"{str(path)!r}: array {name!r} has shape {value.shape}; it must be {shape}")
    return value


def read_npz(path: Path, rate_hz: float | None = None) -> ImuSeries:
    """An IMU series from an ``.npz`` (:func:`read_static`), repaired like a bag's; ``rate_hz`` wins over ``fs_hz``.
    BagError on a missing, non-npz, pickled or malformed file or unusable samples."""
    where = repr(str(path))
    if not path.is_file():
        raise BagError(f"{where}: no such file")
    try:
        with np.load(path, allow_pickle=False) as data:
            missing = [k for k in ("gyro", "accel") if k not in data]
            if missing:
                raise BagError(f"{where} lacks array(s) {', '.join(missing)}: it needs t (or fs_hz), gyro, accel")
            gyro, accel = _npz_array(path, data, "gyro", "(N, 3)"), _npz_array(path, data, "accel", "(N, 3)")
            if "t" in data:
                t = _npz_array(path, data, "t", "(N,)")
                declared = rate_hz
            elif "fs_hz" in data:
                fs = np.asarray(data["fs_hz"])
                if fs.size != 1 or not np.issubdtype(fs.dtype, np.number) or not 0 < float(fs.ravel()[0]) < 1e7:
                    raise BagError(f"{where}: fs_hz must be one positive number of Hz, got {fs!r}")
                declared = rate_hz or float(fs.ravel()[0])
                t = np.arange(gyro.shape[0]) / declared
            else:
                raise BagError(f"{where} needs t [s] or fs_hz [Hz] beside gyro and accel")
    except BagError:
        raise
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise BagError(f"{where} is not a readable .npz with t, gyro, accel arrays: {reason(exc)}") from None
    if not t.shape[0] == gyro.shape[0] == accel.shape[0]:
        raise BagError(f"{where}: t, gyro and accel have {t.shape[0]}, {gyro.shape[0]} and {accel.shape[0]} rows; "
                       "they must have one row per sample")
    try:
        t, (gyro, accel), report = repair_time_series(t, [gyro, accel], max_abs=IMU_MAX_ABS, declared_hz=declared)
    except InputError as exc:
        raise BagError(f"{where}: {exc}") from None
    return ImuSeries(t=t, gyro=gyro, accel=accel, topic=str(path), notes=report.notes("samples"),
                     period=report.period)
