"""White-noise density per axis from stationary samples (AV at τ₀, ``FirstDifferences``) and the corrected IMU's
variance N²·f: from it after ``noise.min_samples``, else from a tracking CMKF's Ŝ (or 95 % upper end), else none."""

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
        """N per axis [u/√Hz] for the nominal ``period`` [s]; NaN before ``min_samples`` differences or without a
        period."""
        if self.n < min_samples or not period:
            return np.full(6, math.nan)
        return self.differences.density(period)

    def relative_std(self, min_samples: int) -> float:
        """Relative standard deviation of N (NaN before ``min_samples`` differences)."""
        return self.differences.relative_std() if self.n >= min_samples else math.nan

    def covariance(self, rate: float, min_samples: int, cmkf: Callable[[], CmkfEstimate]
                   ) -> tuple[np.ndarray | None, str]:
        """N²·f per axis [u²] at IMU rate ``rate`` [Hz] and its source: ``stationary``, ``cmkf`` (identified on every
        axis), ``cmkf_upper_bound`` or ``none``; ``cmkf`` is called only when stationary samples are too few."""
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
