"""Streaming covariance-matching least squares of paper 004 (eq. 35), Ŝ = Σ_k q_k / Σ_k w_k per axis, with the block
sandwich standard error over blocks of :data:`BLOCK` epochs (beyond the paper; docs/cmkf.md, "Uncertainty of S_v")."""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache

import numpy as np
from scipy.stats import t as student_t

#: Epochs per block of the sandwich variance.
BLOCK = 64


class MatchingLeastSquares:
    """Σ q_k / Σ w_k per axis, one epoch at a time, with the block sandwich variance: ``n_axes`` (shared weights),
    ``block`` epochs per block; attributes ``num`` (n,), ``den``, ``count``, ``blocks``."""

    def __init__(self, n_axes: int, block: int = BLOCK) -> None:
        self.n = int(n_axes)
        self.block = int(block)
        self.num = [0.0] * self.n
        self.den = 0.0
        self.count = 0
        self.blocks = 0
        self._q = [0.0] * self.n  # the current block's sums
        self._w = 0.0
        self._k = 0
        self._qq = [0.0] * self.n  # Σ_j Q_j², Σ_j Q_j W_j, Σ_j W_j, Σ_j W_j² over completed blocks
        self._qw = [0.0] * self.n
        self._wc = 0.0
        self._ww = 0.0
        self._working_se: tuple[int, list[float], float] = (-1, [], math.nan)

    def add(self, q: Sequence[float], w: float) -> None:
        """One epoch: its products ``q`` (n) and weight ``w``."""
        num, cur = self.num, self._q
        for i in range(self.n):
            num[i] += q[i]
            cur[i] += q[i]
        self.den += w
        self._w += w
        self.count += 1
        self._k += 1
        if self._k == self.block:
            wj = self._w
            for i in range(self.n):
                self._qq[i] += cur[i] * cur[i]
                self._qw[i] += cur[i] * wj
                cur[i] = 0.0
            self._wc += wj
            self._ww += wj * wj
            self.blocks += 1
            self._w = 0.0
            self._k = 0

    @property
    def estimate(self) -> np.ndarray:
        """Ŝ per axis (NaN before the first epoch)."""
        if self.count == 0 or self.den <= 0.0:
            return np.full(self.n, np.nan)
        return np.array(self.num) / self.den

    def values(self) -> list[float]:
        """Ŝ per axis as floats (NaN before the first epoch): the filters' hot path."""
        if self.count == 0 or self.den <= 0.0:
            return [math.nan] * self.n
        return [x / self.den for x in self.num]

    @property
    def dof(self) -> int:
        """Degrees of freedom of the variance estimate: completed blocks − 1 (0 before two blocks)."""
        return max(self.blocks - 1, 0)

    @property
    def standard_error(self) -> np.ndarray:
        """Standard error of Ŝ per axis, J/(J − 1) · Σ_j (Q_j − Ŝ W_j)² / (Σ_j W_j)² over J blocks (NaN below two)."""
        J = self.blocks
        if J < 2 or self._wc <= 0.0:
            return np.full(self.n, np.nan)
        scale = J / (J - 1) / (self._wc * self._wc)
        out = []
        for s, qq, qw in zip(self.values(), self._qq, self._qw, strict=True):
            out.append(math.sqrt(max(qq - 2.0 * s * qw + s * s * self._ww, 0.0) * scale))
        return np.array(out)

    def working(self, current: Sequence[float], prior: Sequence[float]) -> tuple[list[float], int]:
        """PSD per axis a filter runs with (beyond paper 004; docs/cmkf.md) and the number of axes kept: ``max(Ŝ, se)``
        while Ŝ + t·se > 0, else ``prior``; before two blocks, the last positive value (``current``)."""
        den = self.den
        if self.count == 0 or den <= 0.0:
            return list(current), self.n
        if self.blocks < 2:
            out, kept = [], 0
            for x, c in zip(self.num, current, strict=True):
                v = x / den
                if v > 0.0:
                    out.append(v)
                else:
                    out.append(c)
                    kept += 1
            return out, kept
        if self._working_se[0] != self.blocks:  # refreshed once per block: it changes slowly
            self._working_se = (self.blocks, self.standard_error.tolist(), t_quantile(self.dof))
        _, se, t = self._working_se
        out, kept = [], 0
        for x, e, p in zip(self.num, se, prior, strict=True):
            v = x / den
            if v + t * e > 0.0:
                out.append(v if v > e else e)
            else:
                out.append(p)
                kept += 1
        return out, kept


@lru_cache(maxsize=4096)
def t_quantile(dof: int) -> float:
    """Student's t 0.975 quantile for ``dof`` degrees of freedom (NaN below 1)."""
    return float(student_t.ppf(0.975, dof)) if dof >= 1 else math.nan
