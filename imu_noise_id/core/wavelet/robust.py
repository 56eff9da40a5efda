"""Robust wavelet variance, a bounded-influence M-estimator of one level's coefficient variance (Guerrier, Molinari &
Victoria-Feser, Austrian J. Statistics 43, 2014; Guerrier, Molinari, Victoria-Feser & Xu, arXiv 2001.04214), Tukey's
biweight w_c(r) = (1 − (r/c)²)², |r| < c:

    (1/M_j) Σ_t χ_c(W_{j,t} / ν_j) = 0,   χ_c(r) = w_c(r)·(r² − κ_c),   κ_c = E[w_c(Z) Z²] / E[w_c(Z)],

from the biweight S-scale (breakdown 50 %); efficiency e²/(2 Var χ_c(Z)), e = E[χ'_c(Z) Z]; Gaussian covariance Σ_{k
even} a_k² ρ^k/k!, a_k = E[χ_c(Z) He_k(Z)] (docs/gmwm.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import integrate, optimize, special

from ..errors import InputError

#: Default asymptotic efficiency of the robust estimator (at independent Gaussian coefficients).
DEFAULT_EFFICIENCY = 0.6
#: Hermite orders kept in the covariance (even orders 2..8; the rest of Var χ is lumped into the last one).
HERMITE_ORDERS = (2, 4, 6, 8)


def _normal_pdf(r: float) -> float:
    return math.exp(-0.5 * r * r) / math.sqrt(2.0 * math.pi)


def _hermite_e(k: int, r: float) -> float:
    return float(special.eval_hermitenorm(k, r))


def _expect(fun, c: float) -> float:
    """E f(Z) for an even f that vanishes beyond |r| = c."""
    inner, _ = integrate.quad(lambda r: fun(r) * _normal_pdf(r), 0.0, c, limit=200, epsabs=1e-12)
    return 2.0 * inner


#: Tukey's ρ constant with E ρ(Z) = ½ (breakdown 50 %) for the S-scale start.
S_SCALE_C = 1.5476449
S_SCALE_DELTA = 0.5
#: Coefficients the S-scale start is computed from, at most.
START_SAMPLE = 100_000


def _s_scale(w: np.ndarray, log_nu: float, iterations: int = 30) -> float:
    """log of the biweight S-scale: mean ρ(w/s) = ½, ρ(r) = 1 − (1 − (r/c)²)³ capped at 1."""
    lo, hi = -math.inf, math.inf
    c2 = S_SCALE_C * S_SCALE_C
    for _ in range(iterations):
        t = np.minimum((w * math.exp(-log_nu)) ** 2 / c2, 1.0)
        one_t = 1.0 - t
        f = float(np.mean(1.0 - one_t**3)) - S_SCALE_DELTA
        slope = -float(np.mean(6.0 * t * one_t * one_t))
        lo, hi = (log_nu, hi) if f > 0 else (lo, log_nu)
        new = log_nu - f / slope if slope < 0 else math.nan
        if not (lo < new < hi):
            new = 0.5 * (lo + hi) if math.isfinite(lo) and math.isfinite(hi) else log_nu + (1.0 if f > 0 else -1.0)
        if abs(new - log_nu) < 1e-6:
            return new
        log_nu = new
    return log_nu


@dataclass(frozen=True)
class BiweightScale:
    """The biweight M-estimator at tuning constant ``c`` [ν]: ``kappa`` κ_c, ``e`` = a_2, ``efficiency``, ``hermite``
    a_k²/k!."""

    c: float
    kappa: float
    e: float
    efficiency: float
    hermite: tuple[float, ...]

    @classmethod
    def of(cls, c: float) -> BiweightScale:
        return _biweight(round(float(c), 12))

    @classmethod
    def for_efficiency(cls, efficiency: float) -> BiweightScale:
        """The estimator of ``efficiency`` at the normal (in [0.05, 0.99])."""
        if not 0.05 <= efficiency <= 0.99:
            raise InputError(f"robust efficiency must lie in [0.05, 0.99], got {efficiency}")
        c = optimize.brentq(lambda c: _biweight(c).efficiency - efficiency, 1.0, 60.0, xtol=1e-10)
        return cls.of(c)

    def solve(self, w: np.ndarray, *, tol: float = 1e-8, max_iter: int = 40) -> float:
        """ν̂² solving mean χ_c(w/ν) = 0 by bracketed Newton steps in log ν from the S-scale."""
        w = np.abs(np.asarray(w, dtype=float))
        if w.size == 0 or not np.any(w > 0):
            raise InputError("the robust wavelet variance needs non-zero wavelet coefficients")
        # The start: the S-scale of at most START_SAMPLE coefficients (evenly strided; a start needs no more).
        sample = w[:: max(1, w.size // START_SAMPLE)]
        med = float(np.median(sample))
        log_nu = _s_scale(sample, math.log(med / 0.6744897501960817 if med > 0 else float(np.sqrt(np.mean(w * w)))))
        lo, hi = log_nu - 1.5, log_nu + 1.5
        total = w.size
        w2 = (w[w < self.c * math.exp(hi)]) ** 2  # coefficients beyond c·ν at every ν of the bracket weigh 0
        c2, k2 = self.c * self.c, self.kappa / (self.c * self.c)
        u, uv = np.empty_like(w2), np.empty_like(w2)
        for _ in range(max_iter):
            # t = (r/c)², u = (1 − t)⁺, v = t − κ/c²: χ(r) = c²·u²·v and r·χ'(r) = 2c²·t·u·(u − 2v).
            v = np.multiply(w2, math.exp(-2.0 * log_nu) / c2)
            np.subtract(1.0, v, out=u)
            np.maximum(u, 0.0, out=u)
            v -= k2
            np.multiply(u, v, out=uv)
            s_uuv = float(u @ uv)
            f = c2 * s_uuv / total
            slope = -2.0 * c2 * (s_uuv + k2 * float(u @ u) - 2.0 * float(uv @ v) - 2.0 * k2 * float(uv.sum())) / total
            lo, hi = (log_nu, hi) if f > 0 else (lo, log_nu)
            new = log_nu - f / slope if slope < 0 else math.nan
            if not (lo < new < hi):
                new = 0.5 * (lo + hi)
            if abs(new - log_nu) < tol:
                log_nu = new
                break
            log_nu = new
        return math.exp(2.0 * log_nu)


@lru_cache(maxsize=64)
def _biweight(c: float) -> BiweightScale:
    def weight(r: float) -> float:
        return max(1.0 - (r / c) ** 2, 0.0) ** 2

    kappa = _expect(lambda r: weight(r) * r * r, c) / _expect(weight, c)

    def chi(r: float) -> float:
        return weight(r) * (r * r - kappa)

    terms = [_expect(lambda r, k=k: chi(r) * _hermite_e(k, r), c) for k in HERMITE_ORDERS]
    e = terms[0]
    var = _expect(lambda r: chi(r) ** 2, c)
    hermite = [a * a / math.factorial(k) for a, k in zip(terms, HERMITE_ORDERS, strict=True)]
    hermite[-1] += max(var - sum(hermite), 0.0)
    return BiweightScale(c, kappa, e, e * e / (2.0 * var), tuple(hermite))


#: Hampel identifier of :func:`hampel_clean`: half window (samples) and threshold (robust standard deviations).
HAMPEL_HALF_WINDOW, HAMPEL_THRESHOLD = 3, 6.5


def hampel_clean(y: np.ndarray, half_window: int = HAMPEL_HALF_WINDOW,
                 threshold: float = HAMPEL_THRESHOLD) -> tuple[np.ndarray, np.ndarray]:
    """(``y`` with isolated outliers replaced by the running median of 2h + 1 samples, their mask); outliers lie
    beyond ``threshold`` × 1.4826·MAD from it (Hampel)."""
    y = np.asarray(y, dtype=float)
    h = int(half_window)
    bad = np.zeros(y.size, bool)
    if y.size < 2 * h + 1:
        return y, bad
    windows = np.lib.stride_tricks.sliding_window_view(y, 2 * h + 1)
    med = np.empty_like(y)
    med[h:-h] = np.median(windows, axis=1)
    med[:h], med[-h:] = med[h], med[-h - 1]
    resid = y - med
    spread = 1.4826 * float(np.median(np.abs(resid)))
    if spread <= 0:
        return y, bad
    bad = np.abs(resid) > threshold * spread
    if not bad.any():
        return y, bad
    out = y.copy()
    out[bad] = med[bad]
    return out, bad
