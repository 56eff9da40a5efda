"""The white-noise density per axis from the stationary samples, and the covariance of the corrected IMU.

The density is the Allan variance at τ₀ of the samples that passed the stationarity guard
(:class:`~imu_noise_id.core.white_noise.FirstDifferences`: differences never span a pause). The variance written
into ``~/imu_corrected`` is N²·f: from this density once ``noise.min_samples`` differences exist, before that from
the CMKF's Ŝ while it is tracking (its 95 % upper bound on an axis where Ŝ is not identifiable), else unknown.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ...core.cmkf.robot import CmkfEstimate
from ...core.white_noise import FirstDifferences


class StationaryNoise:
    """White-noise density per axis (AXES order) from consecutive stationary samples."""

    def __init__(self) -> None:
        self.differences = FirstDifferences(6)

    @property
    def n(self) -> int:
        """Stationary sample differences used."""
        return self.differences.n

    def add(self, t: float, sample: np.ndarray) -> None:
        """A stationary sample that passed the guard."""
        self.differences.add(t, sample)

    def break_chain(self) -> None:
        """Motion or a gap: no difference across it."""
        self.differences.break_chain()

    def density(self, min_samples: int, period: float | None) -> np.ndarray:
        """N per axis [u/√Hz] for the nominal sampling ``period`` [s] (not the stamps' intervals, which bursts of
        host-stamped messages make tiny); NaN before ``min_samples`` differences or while the period is unknown."""
        if self.n < min_samples or not period:
            return np.full(6, math.nan)
        return self.differences.density(period)

    def relative_std(self, min_samples: int) -> float:
        """Relative standard deviation of N (NaN before ``min_samples`` differences)."""
        return self.differences.relative_std() if self.n >= min_samples else math.nan

    def covariance(self, rate: float, min_samples: int, cmkf: Callable[[], CmkfEstimate]
                   ) -> tuple[np.ndarray | None, str]:
        """N²·f per axis [u²] for the IMU rate ``rate`` [Hz] and its source: ``stationary`` (this density),
        ``cmkf`` (Ŝ_g, Ŝ_v of a tracking CMKF, identified on every axis), ``cmkf_upper_bound`` (where an axis is not
        identifiable, its 95 % upper bound: a conservative variance) or ``none`` (never the filter's prior).
        ``cmkf`` gives the CMKF's estimate; it is asked for only when the stationary samples are too few."""
        if not math.isfinite(rate):
            return None, "none"
        if self.n >= min_samples:
            return self.differences.variance() / 2.0, "stationary"  # σ² per sample = N²·f
        est = cmkf()
        if est.status != "tracking":
            return None, "none"
        psd = []
        bounded = False
        for estimate in (est.gyro_psd, est.accel_psd):
            for value, upper, verdict in zip(estimate.value, estimate.upper95, estimate.verdict, strict=True):
                if verdict == "identified":
                    psd.append(value)
                elif verdict == "not_identifiable":
                    psd.append(upper)
                    bounded = True
                else:
                    return None, "none"
        return np.array(psd) * rate, "cmkf_upper_bound" if bounded else "cmkf"
