"""The tail of the maximum of a correlated scan statistic (a step searched at every sample), beyond Bonferroni.

For a standardized Gaussian scan T_k whose neighbours correlate as ρ_k = Corr(T_k, T_{k+1}) = 1 − θ_k (θ_k small:
locally an Ornstein–Uhlenbeck process), Siegmund's approximation with the discrete overshoot correction ν is

    P(max_k |T_k| > b) ≈ 2 Φ̄(b) + 2 b φ(b) Σ_k θ_k ν(b √(2 θ_k)),
    ν(x) ≈ (2/x)(Φ(x/2) − ½) / ((x/2) Φ(x/2) + φ(x/2))

(James, James & Siegmund 1987, Biometrika 74, 71–83, for the change-point scan of white noise; Siegmund & Yakir 2007,
*The Statistics of Gene Mapping*, ch. 4, for ν; the first position's own tail 2 Φ̄(b) added, the whole capped at
Bonferroni's). It falls to Bonferroni's 2 Φ̄(b) per position where neighbours are nearly independent (θ_k → 1),
and is far below it where a position's statistic is shared by its neighbours, as a step
seen through a whitening filter with a slow pole is. Why: docs/analysis.md, "Why the watch's step test reads the
scan's own correlation"."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize
from scipy.fft import next_fast_len
from scipy.special import ndtr, ndtri

from .whitening import WhiteningFilter

#: √(2π), the standard normal density's normalisation.
_SQRT_2PI = math.sqrt(2.0 * math.pi)


def _normal_pdf(x: np.ndarray | float) -> np.ndarray | float:
    """φ(x) (as scipy.stats.norm.pdf computes it, without its per-call argument handling: this module's scans call it
    hundreds of times per window)."""
    return np.exp(-(np.asarray(x) ** 2) / 2.0) / _SQRT_2PI


def overshoot(x: np.ndarray) -> np.ndarray:
    """Siegmund's discrete overshoot correction ν(x) (module docstring); ν(0) = 1, ν(x) ≈ 2/x² for large x."""
    x = np.asarray(x, dtype=float)
    half = np.maximum(x / 2.0, 1e-12)
    cdf = ndtr(half)
    return np.where(x > 1e-9, (cdf - 0.5) / half / (half * cdf + _normal_pdf(half)), 1.0)


@dataclass(frozen=True)
class ShiftedStep:
    """The whitened constant ``s`` (N,) against its shifts x_k (s delayed by k samples, zero before): the FFT ``fs`` of
    ``s`` zero-padded to ``size`` (a linear, not circular, correlation), a_k = ⟨x_k, s⟩ (``a``), ‖s‖² (``s2``) and
    ‖x_k‖² = Σ_{j < N−k} s_j² (``tail``)."""

    fs: np.ndarray
    size: int
    a: np.ndarray
    s2: float
    tail: np.ndarray

    @classmethod
    def of(cls, s: np.ndarray) -> ShiftedStep:
        s = np.asarray(s, dtype=float)
        n = s.size
        size = next_fast_len(2 * n - 1, real=True)
        fs = np.fft.rfft(s, size)
        a = np.fft.irfft(fs * np.conj(fs), size)[:n]
        return cls(fs, size, a, float(s @ s), np.cumsum(s**2)[::-1])  # tail[k]: cumsum reversed, k ↔ N−k−1


def step_scan_neighbour_correlation(s: np.ndarray, min_segment: int) -> np.ndarray:
    """ρ_k = Corr(T_k, T_{k+1}) of :func:`~.detectors.step_scan`'s statistics for the whitened constant ``s`` (N,),
    at k = ``min_segment`` … N − ``min_segment`` − 2: with x_k the step at k seen through the filter (s shifted by k)
    and r_k = x_k − (⟨x_k, s⟩/‖s‖²) s its part the level does not explain, ρ_k = ⟨r_k, r_{k+1}⟩/(‖r_k‖ ‖r_{k+1}‖),
    ⟨x_k, x_{k+1}⟩ = Σ_{j < N−k−1} s_j s_{j+1}."""
    s = np.asarray(s, dtype=float)
    n = s.size
    shifted = ShiftedStep.of(s)
    a, s2 = shifted.a, shifted.s2
    lag_one = np.concatenate([np.cumsum(s[:-1] * s[1:])[::-1], [0.0]])  # ⟨x_k, x_{k+1}⟩, index k
    k = np.arange(min_segment, n - min_segment - 1)
    norm2 = shifted.tail - a**2 / s2
    cross = lag_one[k] - a[k] * a[k + 1] / s2
    return cross / np.sqrt(np.maximum(norm2[k] * norm2[k + 1], 1e-300))


def scan_max_sf(b: float, rho: np.ndarray) -> float:
    """P(max_k |T_k| > ``b``) for a standardized Gaussian scan with neighbour correlations ``rho`` (module docstring),
    at most Bonferroni's over the len(rho) + 1 positions and at most 1."""
    theta = np.clip(1.0 - np.asarray(rho, dtype=float), 0.0, 1.0)
    siegmund = 2.0 * b * float(_normal_pdf(b)) * float(np.sum(theta * overshoot(b * np.sqrt(2.0 * theta))))
    tail = float(ndtr(-b))  # Φ̄(b)
    return min(1.0, siegmund + 2.0 * tail, 2.0 * (theta.size + 1) * tail)


def scan_threshold(alpha: float, rho: np.ndarray) -> float:
    """The b at which :func:`scan_max_sf` equals ``alpha`` (0 < alpha < 1)."""
    upper = -float(ndtri(alpha / (2.0 * (np.size(rho) + 1))))  # Bonferroni's, never exceeded
    lower = -float(ndtri(alpha / 2.0))
    if scan_max_sf(lower, rho) <= alpha:
        return lower
    return float(optimize.brentq(lambda b: math.log(scan_max_sf(b, rho)) - math.log(alpha), lower, upper,
                                 xtol=1e-6))


@dataclass(frozen=True)
class StepScanTail:
    """The tail of :func:`~.detectors.step_scan`'s maximum on ``n`` samples seen through one whitening filter, segments
    of at least ``min_segment``: its neighbour correlations ``rho`` once, thresholds per level as asked."""

    n: int
    min_segment: int
    rho: np.ndarray
    _thresholds: dict[float, float] = field(default_factory=dict, compare=False, repr=False)

    @classmethod
    def of(cls, whitening: WhiteningFilter, n: int, min_segment: int) -> StepScanTail:
        """The tail for ``n`` samples whitened by ``whitening``."""
        rho = step_scan_neighbour_correlation(whitening.whitened_constant(n), min_segment)
        return cls(int(n), int(min_segment), rho)

    def sf(self, b: float) -> float:
        """P(max_k |T_k| > b) (:func:`scan_max_sf`)."""
        return scan_max_sf(b, self.rho)

    def threshold(self, alpha: float) -> float:
        """The level-``alpha`` threshold of max_k |T_k| (:func:`scan_threshold`), computed once per level."""
        if alpha not in self._thresholds:
            self._thresholds[alpha] = scan_threshold(alpha, self.rho)
        return self._thresholds[alpha]
