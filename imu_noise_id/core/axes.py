"""Axis names (``gyro_x`` … ``accel_z``; rad/s and m/s², REP-103/REP-145) and the IMU time-series containers."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .errors import InputError
from .timing import SamplePeriod, estimate_period

GYRO_AXES: tuple[str, ...] = ("gyro_x", "gyro_y", "gyro_z")
ACCEL_AXES: tuple[str, ...] = ("accel_x", "accel_y", "accel_z")
AXES: tuple[str, ...] = GYRO_AXES + ACCEL_AXES

UNITS: dict[str, str] = {**dict.fromkeys(GYRO_AXES, "rad/s"), **dict.fromkeys(ACCEL_AXES, "m/s^2")}
#: Each sensor's name ("gyro", "accel") and its axes.
SENSORS: tuple[tuple[str, tuple[str, ...]], ...] = (("gyro", GYRO_AXES), ("accel", ACCEL_AXES))


def sensor_of(axis: str) -> str:
    """The sensor ("gyro" or "accel") of ``axis``; ValueError if not one of :data:`AXES`."""
    for sensor, axes in SENSORS:
        if axis in axes:
            return sensor
    raise ValueError(f"unknown axis {axis!r}: expected one of {', '.join(AXES)}")


def axis_index(name: str) -> int:
    """Column of ``name`` in :meth:`ImuSeries.samples`; ValueError if not one of :data:`AXES`."""
    try:
        return AXES.index(name)
    except ValueError:
        raise ValueError(f"unknown axis {name!r}: expected one of {', '.join(AXES)}") from None


@dataclass
class ImuSeries:
    """IMU samples on a common time base.

    Attributes
    ----------
    t : (N,) sample times [s]; gyro : (N, 3) rate [rad/s]; accel : (N, 3) specific force [m/s²] (gravity included)
    frame_id, topic, notes; orientation_xyzw : (N, 4) the sensor's orientation (NaN rows: none, REP-145), or None
    period : the reader's :class:`~.timing.SamplePeriod`, or None (estimated from ``t``)
    """

    t: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    frame_id: str = "imu_link"
    topic: str = ""
    notes: list[str] = field(default_factory=list)
    orientation_xyzw: np.ndarray | None = None
    period: SamplePeriod | None = None

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, dtype=float)
        self.gyro = np.asarray(self.gyro, dtype=float).reshape(-1, 3)
        self.accel = np.asarray(self.accel, dtype=float).reshape(-1, 3)
        n = self.t.shape[0]
        if self.gyro.shape[0] != n or self.accel.shape[0] != n:
            raise ValueError(
                f"ImuSeries: t has {n} samples but gyro has {self.gyro.shape[0]} and accel "
                f"{self.accel.shape[0]}"
            )
        if self.orientation_xyzw is not None:
            self.orientation_xyzw = np.asarray(self.orientation_xyzw, dtype=float)
            if self.orientation_xyzw.shape != (n, 4):
                raise ValueError(
                    f"ImuSeries: orientation_xyzw must have shape ({n}, 4), got {self.orientation_xyzw.shape}"
                )

    def __len__(self) -> int:
        return int(self.t.shape[0])

    def sample_period(self) -> SamplePeriod:
        """The reader's period estimate, or :func:`~imu_noise_id.core.timing.estimate_period` of ``t``."""
        return self.period if self.period is not None else estimate_period(self.t)

    @property
    def dt(self) -> float:
        """Sampling period [s]; InputError when the stamps cannot give it."""
        return self.sample_period().require()

    @property
    def rate(self) -> float:
        """Sampling rate [Hz] (1 / :attr:`dt`)."""
        return 1.0 / self.dt

    def between(self, start_s: float, end_s: float) -> ImuSeries:
        """Samples from ``start_s`` to ``end_s`` [s] after the first (both included, ``end_s`` may be inf) with a
        note saying so (and, from ``start_s`` > 0 on, that times given for them are from their first sample);
        InputError for an empty, reversed or one-sample span."""
        elapsed = self.t - self.t[0]
        if not (math.isfinite(start_s) and 0.0 <= start_s < end_s):
            raise InputError(f"{self.topic or 'input'}: span {start_s:g}:{end_s:g} s must be two times [s] from "
                             "the first sample, the first ≥ 0 and below the second (inf: to the end)")
        keep = (elapsed >= start_s) & (elapsed <= end_s)
        if np.count_nonzero(keep) < 2:
            raise InputError(f"{self.topic or 'input'}: span {start_s:g}:{end_s:g} s holds fewer than two samples "
                             f"of the record's 0–{elapsed[-1]:.4g} s")
        orientation = self.orientation_xyzw[keep] if self.orientation_xyzw is not None else None
        origin = f"; times given for it are from its first sample, {start_s:g} s into the record" if start_s > 0 else ""
        note = (f"analysed t = {start_s:g}–{min(end_s, float(elapsed[-1])):.4g} s from the first sample (span) of "
                f"the record's 0–{elapsed[-1]:.4g} s{origin}")
        return ImuSeries(t=self.t[keep], gyro=self.gyro[keep], accel=self.accel[keep], frame_id=self.frame_id,
                         topic=self.topic, notes=[*self.notes, note], orientation_xyzw=orientation,
                         period=self.period)

    def samples(self) -> np.ndarray:
        """All six axes as one (N, 6) array in :data:`AXES` order."""
        return np.hstack([self.gyro, self.accel])

    def axis(self, name: str) -> np.ndarray:
        """One axis by name (see :data:`AXES`)."""
        i = axis_index(name)
        return self.gyro[:, i] if i < 3 else self.accel[:, i - 3]


@dataclass
class ScalarSeries:
    """A scalar time series, e.g. sensor_msgs/Temperature [°C]."""

    t: np.ndarray
    value: np.ndarray
    topic: str = ""


@dataclass
class OdometrySeries:
    """nav_msgs/Odometry: ``t`` (M,) [s], ``position`` (M, 3) [m], ``orientation_xyzw`` (M, 4), ``linear_velocity``
    [m/s], ``angular_velocity`` [rad/s] (M, 3) in ``child_frame_id`` (REP-105), covariances (M, 6, 6)."""

    t: np.ndarray
    position: np.ndarray
    orientation_xyzw: np.ndarray
    linear_velocity: np.ndarray
    angular_velocity: np.ndarray
    pose_covariance: np.ndarray
    twist_covariance: np.ndarray
    frame_id: str = "odom"
    child_frame_id: str = "base_link"
    topic: str = ""

    def __len__(self) -> int:
        return int(np.asarray(self.t).shape[0])
