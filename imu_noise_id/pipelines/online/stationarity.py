"""Stationarity for the online identification: :class:`StationarityDetector` (odometry twist and IMU statistics,
with hysteresis) and :class:`StationaryGate` (stationary samples wait ``stationary.guard`` seconds and are dropped
if motion is detected meanwhile)."""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from .config import OnlineConfig


@dataclass
class StationarityDetector:
    """Stationary / moving with hysteresis: IMU "still" when the weighted (``window``) std per gyro / accelerometer axis
    is below ``max_gyro_std`` / ``max_accel_std`` and |mean rate − gyro bias| below ``max_gyro_rate``; fresh odometry
    "still" below its speed thresholds (absent: IMU alone unless ``require_odometry``); stationary after ``enter_delay``
    seconds of "still", moving at the first contrary sample."""

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


class StationaryGate:
    """:class:`StationarityDetector` followed by the guard delay line; attributes ``detector``, ``transitions``."""

    def __init__(self, config: OnlineConfig) -> None:
        self.detector = StationarityDetector(config)
        self.transitions = 0
        self._guard: deque[tuple[float, np.ndarray]] = deque()

    @property
    def stationary(self) -> bool:
        """Whether the platform is stationary now."""
        return self.detector.stationary

    def configure(self, config: OnlineConfig) -> None:
        """Apply changed parameters."""
        self.detector.config = config

    def update(self, t: float, sample: np.ndarray, gyro_bias: np.ndarray
               ) -> tuple[bool, list[tuple[float, np.ndarray]]]:
        """One IMU sample (6 values); returns whether it ended a stationary stretch, and the samples released
        from the guard (stamp, values) for the noise identification."""
        detector = self.detector
        was = detector.stationary
        stationary = detector.update_imu(t, sample, gyro_bias)
        ended = False
        if stationary != was:
            self.transitions += 1
            if not stationary:
                self._guard.clear()
                ended = True
        released = []
        if stationary:
            guard = self._guard
            guard.append((t, sample))
            horizon = t - detector.config.stationary_guard
            while guard and guard[0][0] <= horizon:
                released.append(guard.popleft())
        return ended, released

    def interrupt(self) -> None:
        """A gap in the IMU stamps: forget the guarded samples and start the decision afresh."""
        self._guard.clear()
        self.detector.reset()
