"""The Fourier sum D(f) = Σ_k x_k e^{−2πif k·dt} near one frequency f₀, each in O(blocks) after one O(N) pass (why:
docs/diagnostics.md). With u_k = x_k e^{−2πi f₀ k·dt} in B blocks of L samples (k = jL + r)

    D(f₀ + δ) = Σ_j e^{−2πiδ jL·dt} Σ_{p=0}^{P−1} (−2πiδ·dt)^p / p! · M_p[j],    M_p[j] = Σ_r u_{jL+r} r^p,

with error ≤ (2π|δ|(L − 1)·dt)^P / P! · Σ|x_k| ≤ 10⁻¹² Σ|x_k| for |δ| ≤ :attr:`LocalDft.reach`."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Blocks the record is cut into.
BLOCKS = 4096
#: Terms of the Taylor series kept.
TERMS = 4


@dataclass(frozen=True)
class LocalDft:
    """The moments M_p[j] (``moments``, (TERMS, B) complex) of a record of ``n`` samples at ``dt`` [s] demodulated at
    ``frequency`` f₀ [Hz], ``block`` = L samples per block."""

    frequency: float
    dt: float
    n: int
    block: int
    moments: np.ndarray

    @classmethod
    def of(cls, x: np.ndarray, dt: float, frequency: float) -> LocalDft:
        """The moments of ``x`` (NaN as 0) at ``frequency`` [Hz] and period ``dt`` [s]."""
        x = np.nan_to_num(np.asarray(x, dtype=float))
        n = x.size
        block = max(1, math.ceil(n / BLOCKS))
        padded = np.zeros(math.ceil(n / block) * block)
        padded[:n] = x
        k = np.arange(padded.size)
        u = (padded * np.exp(-2j * math.pi * frequency * dt * k)).reshape(-1, block)
        r = np.arange(block, dtype=float)
        moments = np.array([u @ r**p for p in range(TERMS)])
        return cls(float(frequency), float(dt), int(n), int(block), moments)

    @property
    def reach(self) -> float:
        """The largest |δ| [Hz] whose truncation error is ≤ 10⁻¹² Σ|x_k|."""
        if self.block == 1:  # r = 0 only: the series is exact
            return math.inf
        limit = (1e-12 * math.factorial(TERMS)) ** (1.0 / TERMS)
        return limit / (2.0 * math.pi * (self.block - 1) * self.dt)

    def at(self, frequency: float) -> complex:
        """D(``frequency``); ValueError beyond :attr:`reach` of f₀."""
        delta = frequency - self.frequency
        if abs(delta) > self.reach:
            raise ValueError(f"{frequency} Hz is beyond the reach ({self.reach:.3g} Hz) of {self.frequency} Hz")
        a = -2j * math.pi * delta * self.dt
        series = sum(a**p / math.factorial(p) * self.moments[p] for p in range(TERMS))
        starts = np.arange(self.moments.shape[1]) * self.block
        return complex(np.exp(a * starts) @ series)
