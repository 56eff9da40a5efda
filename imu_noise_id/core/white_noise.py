"""White-noise density from first differences, streaming or batch: σ² = ½ Var(y_{k+1} − y_k) (the AV at Δt, IEEE Std
952), N = √(σ²·Δt); bias removed, RW/GM increments add q/2; no difference across a pause (``break_chain``)."""

from __future__ import annotations

import math

import numpy as np


class FirstDifferences:
    """Running sums of the first differences of ``channels`` channels and the white-noise density from them."""

    def __init__(self, channels: int = 1) -> None:
        self.channels = int(channels)
        self.n = 0  # differences accumulated
        self.sum_dt = 0.0  # their time spans [s] (streaming use with stamps)
        self._sum = np.zeros(self.channels)
        self._sum_sq = np.zeros(self.channels)
        self._prev: np.ndarray | None = None
        self._prev_t = 0.0

    def add(self, t: float, sample: np.ndarray) -> None:
        """One sample (``channels`` values) at time ``t`` [s], differenced with the chain's previous one."""
        prev = self._prev
        if prev is not None:
            d = sample - prev
            self._sum += d
            self._sum_sq += d * d
            self.n += 1
            self.sum_dt += t - self._prev_t
        self._prev = sample
        self._prev_t = t

    def add_series(self, y: np.ndarray) -> None:
        """Consecutive samples (k,) or (k, channels) as a chain of their own."""
        d = np.diff(np.asarray(y, dtype=float).reshape(len(y), self.channels), axis=0)
        self._sum += d.sum(axis=0)
        self._sum_sq += (d * d).sum(axis=0)
        self.n += d.shape[0]
        self._prev = None

    def break_chain(self) -> None:
        """The next sample starts a new chain (no difference across a pause or a gap)."""
        self._prev = None

    def variance(self) -> np.ndarray:
        """Centred variance of the differences per channel (NaN before the first)."""
        if self.n == 0:
            return np.full(self.channels, math.nan)
        mean = self._sum / self.n
        return np.maximum(self._sum_sq / self.n - mean * mean, 0.0)

    def density(self, dt: float | None = None) -> np.ndarray:
        """N = √(Var(d)/2 · Δt) [u/√Hz] per channel; ``dt`` [s], or None for the stamped differences' mean span."""
        if dt is None:
            dt = self.sum_dt / self.n if self.n else math.nan
        return np.sqrt(0.5 * self.variance() * dt)

    def relative_std(self) -> float:
        """Approximate relative std √(3/n)/2 of N for Gaussian white noise."""
        return math.sqrt(3.0 / self.n) / 2.0 if self.n else math.nan
