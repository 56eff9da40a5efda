"""Building blocks of the online identification: stamp checks, stationarity with hysteresis and a windowed
percentile buffer (each plain Python/numpy, tested on its own)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .online_config import OnlineConfig


@dataclass
class StampChecker:
    """Header-stamp checks for one input stream.

    ``check(t)`` returns ``"ok"``, ``"gap"`` (accepted, after a period longer than ``gap_factor`` × the
    nominal period), ``"restart"`` (accepted: ``backward_reset_count`` consecutive backward stamps mean the
    source restarted), or the reason for rejecting the message: ``"bad_stamp"`` (zero or not finite),
    ``"duplicate"`` or ``"backward"``.
    """

    gap_factor: float = 10.0
    backward_reset_count: int = 50
    last: float | None = None
    period: float | None = None
    consecutive_backward: int = 0
    counts: dict[str, int] = field(
        default_factory=lambda: dict.fromkeys(("ok", "gap", "restart", "bad_stamp", "duplicate", "backward"), 0)
    )

    def check(self, t: float) -> str:
        verdict = self._verdict(t)
        self.counts[verdict] += 1
        return verdict

    def _verdict(self, t: float) -> str:  # noqa: PLR0911 - one return per verdict
        if not math.isfinite(t) or t <= 0.0:
            return "bad_stamp"
        last = self.last
        if last is None:
            self.last = t
            return "ok"
        dt = t - last
        if dt == 0.0:
            return "duplicate"
        if dt < 0.0:
            self.consecutive_backward += 1
            if self.consecutive_backward >= self.backward_reset_count:
                self.consecutive_backward = 0
                self.last = t
                self.period = None
                return "restart"
            return "backward"
        self.consecutive_backward = 0
        self.last = t
        period = self.period
        if period is None:
            self.period = dt
            return "ok"
        if dt > self.gap_factor * period:
            return "gap"
        self.period = period + 0.01 * (dt - period)
        return "ok"

    @property
    def rate(self) -> float:
        """Nominal rate from the header stamps [Hz] (NaN until two stamps were seen)."""
        return 1.0 / self.period if self.period else math.nan


@dataclass
class StationarityDetector:
    """Stationary / moving decision from the odometry twist and the IMU statistics, with hysteresis.

    The IMU says "still" when the exponentially weighted (time constant ``window``) standard deviation of every
    gyro axis is below ``max_gyro_std``, of every accelerometer axis below ``max_accel_std``, and the weighted
    mean angular rate minus the current gyro bias estimate is below ``max_gyro_rate`` in norm (a constant turn
    has a small standard deviation). Fresh odometry (stamp within ``odom_timeout`` of the IMU stamp) says
    "still" when its linear and angular speeds are below their thresholds; without fresh odometry the IMU
    decides alone unless ``require_odometry``. The platform becomes stationary after the evidence said "still"
    for ``enter_delay`` seconds without interruption and stops being stationary at the first contrary sample.
    """

    config: OnlineConfig
    stationary: bool = False
    still_since: float | None = None
    stationary_since: float | None = None
    odom_t: float | None = None
    odom_still: bool = False
    odom_fresh: bool = False
    imu_still: bool = False
    _mean: np.ndarray | None = None
    _var: np.ndarray | None = None
    _last_t: float | None = None

    def reset(self) -> None:
        """Forget the IMU statistics and the hysteresis (after a gap or a restart); keep the odometry."""
        self.stationary = False
        self.still_since = None
        self.stationary_since = None
        self._mean = None
        self._var = None
        self._last_t = None

    def update_odometry(self, t: float, linear_speed: float, angular_speed: float) -> None:
        if self.odom_t is not None and t < self.odom_t:
            return
        cfg = self.config
        self.odom_t = t
        self.odom_still = (linear_speed <= cfg.stationary_max_linear_speed
                           and angular_speed <= cfg.stationary_max_angular_speed)

    def update_imu(self, t: float, sample: np.ndarray, gyro_bias: np.ndarray) -> bool:
        """Add one IMU sample (6 values in :data:`~imu_noise_id.core.axes.AXES` order); the new state."""
        cfg = self.config
        if self._mean is None:
            self._mean = sample.copy()
            self._var = np.zeros(6)
            self._last_t = t
            self.imu_still = False
        else:
            alpha = min(1.0, (t - self._last_t) / cfg.stationary_window)
            self._last_t = t
            delta = sample - self._mean
            self._mean += alpha * delta
            self._var = (1.0 - alpha) * (self._var + alpha * delta * delta)
            std = np.sqrt(self._var)
            turn = self._mean[:3] - gyro_bias
            self.imu_still = bool(
                std[0] <= cfg.stationary_max_gyro_std and std[1] <= cfg.stationary_max_gyro_std
                and std[2] <= cfg.stationary_max_gyro_std and std[3] <= cfg.stationary_max_accel_std
                and std[4] <= cfg.stationary_max_accel_std and std[5] <= cfg.stationary_max_accel_std
                and math.sqrt(float(turn @ turn)) <= cfg.stationary_max_gyro_rate
            )
        self.odom_fresh = self.odom_t is not None and abs(t - self.odom_t) <= cfg.odom_timeout
        if self.odom_fresh:
            still = self.imu_still and self.odom_still
        else:
            still = self.imu_still and not cfg.stationary_require_odometry
        if not still:
            self.still_since = None
            self.stationary = False
            self.stationary_since = None
            return False
        if self.still_since is None:
            self.still_since = t
        if not self.stationary and t - self.still_since >= cfg.stationary_enter_delay:
            self.stationary = True
            self.stationary_since = t
        return self.stationary


@dataclass
class WindowStats:
    """Percentiles over the last ``size`` values of a stream of numbers (processing times, NIS)."""

    size: int = 4096
    _buf: np.ndarray | None = None
    _i: int = 0
    count: int = 0

    def add(self, value: float) -> None:
        if self._buf is None or self._buf.shape[0] != self.size:
            self._buf = np.empty(self.size)
            self._i = 0
        self._buf[self._i] = value
        self._i = (self._i + 1) % self.size
        self.count += 1

    def values(self) -> np.ndarray:
        if self._buf is None:
            return np.empty(0)
        return self._buf[: min(self.count, self.size)]

    def percentile(self, q: float) -> float:
        v = self.values()
        return float(np.percentile(v, q)) if v.size else math.nan
