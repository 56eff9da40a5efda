"""White-noise density from first differences: the Allan variance at τ₀ = Δt, streaming or batch.

For a white-noise sequence of per-sample variance σ², the first differences ``d_k = y_{k+1} − y_k`` have
variance 2σ², so ``σ² = ½ Var(d)`` — the Allan variance at τ = Δt (IEEE Std 952) — and the density is
``N = √(σ²·Δt)`` (:func:`imu_noise_id.core.noise.units.white_noise_density`). Differences remove the bias and
attenuate slow drifts (RW, GM with τ ≫ Δt); quantisation noise and vibration are included. RW/GM increments
inflate the estimate slightly (by q/2 per sample).

:class:`FirstDifferences` keeps the sums of the differences (``Var(d)`` is their centred sample variance), so the
same estimate serves whole arrays (``imu-noise-id identify``'s ``auto`` white-noise ranges,
:func:`imu_noise_id.core.hypotheses.config.white_noise_estimate`) and the online node, which adds stationary
samples one at a time and never differences across a pause (:meth:`FirstDifferences.break_chain`).
"""

from __future__ import annotations

import math

import numpy as np


class FirstDifferences:
    """Running sums of the first differences of one or more channels and the white-noise density from them.

    Parameters
    ----------
    channels : int
        Number of channels (columns) of every sample.
    """

    def __init__(self, channels: int = 1) -> None:
        self.channels = int(channels)
        self.n = 0  # differences accumulated
        self.sum_dt = 0.0  # their time spans [s] (streaming use with stamps)
        self._sum = np.zeros(self.channels)
        self._sum_sq = np.zeros(self.channels)
        self._prev: np.ndarray | None = None
        self._prev_t = 0.0

    def add(self, t: float, sample: np.ndarray) -> None:
        """One sample (``channels`` values) at time ``t`` [s], differenced with the previous one of the chain."""
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
        """Consecutive samples, shape (k,) for one channel or (k, channels), as one chain of their own."""
        d = np.diff(np.asarray(y, dtype=float).reshape(len(y), self.channels), axis=0)
        self._sum += d.sum(axis=0)
        self._sum_sq += (d * d).sum(axis=0)
        self.n += d.shape[0]
        self._prev = None

    def break_chain(self) -> None:
        """The next sample starts a new chain (no difference across a pause or a gap)."""
        self._prev = None

    def variance(self) -> np.ndarray:
        """Centred sample variance of the differences per channel (NaN before the first difference)."""
        if self.n == 0:
            return np.full(self.channels, math.nan)
        mean = self._sum / self.n
        return np.maximum(self._sum_sq / self.n - mean * mean, 0.0)

    def density(self, dt: float | None = None) -> np.ndarray:
        """White-noise density N = √(Var(d)/2 · Δt) per channel [u/√Hz].

        ``dt`` is the sampling period [s]; None uses the mean time span of the differences added with stamps.
        """
        if dt is None:
            dt = self.sum_dt / self.n if self.n else math.nan
        return np.sqrt(0.5 * self.variance() * dt)

    def relative_std(self) -> float:
        """Approximate relative standard deviation of N for white noise: √(3/n)/2.

        For Gaussian white noise ``d_k`` has var(d_k²) = 8σ⁴ and cov(d_k², d_{k+1}²) = 2σ⁴, so
        var(σ̂²) = var(Σd²/2n) ≈ 12nσ⁴/4n² = 3σ⁴/n; N ∝ √σ̂² halves the relative error.
        """
        return math.sqrt(3.0 / self.n) / 2.0 if self.n else math.nan
