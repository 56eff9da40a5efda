"""Exact likelihood of a record's block sums: a statistic of fixed size for the long-τ part (beyond the papers).

With M ≤ :data:`MAX_BLOCKS` blocks of L samples and partial sums x_k = y_0 + … + y_{k−1}, the differences
D_k = x_{(k+2)L} − 2 x_{(k+1)L} + x_{kL} (k = 0 … M − 2) are stationary and Gaussian with autocovariance

    γ_D(h) = K((h−2)L) − 4 K((h−1)L) + 6 K(hL) − 4 K((h+1)L) + K((h+2)L),

K the components' generalised covariance of the partial sums (``Component.sum_covariance``, exact for the sampled
components). Their log-likelihood is exact by the Cholesky factor of the Toeplitz covariance, O(M³) whatever N."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve, cholesky, solve_triangular, toeplitz
from scipy.optimize import minimize

from ...errors import InputError
from ...noise.components import GM, RW, WN, Component
from ...noise.flicker import BI
from ...quality import interpolate_missing
from .whittle import with_log_parameters

#: Most blocks a record is cut into (an evaluation is O(M³)).
MAX_BLOCKS = 256
#: Fewest blocks for a statistic worth its name.
MIN_BLOCKS = 32
#: Component types whose parameters the block sums estimate; the others (filters, resonances, quantisation) keep
#: their values.
SLOW_TYPES = (WN, RW, GM, BI)


@dataclass(frozen=True)
class BlockSums:
    """Demeaned differences of block sums: ``d`` (M − 1,) [u·samples], ``block`` L, ``dt`` [s], ``n`` samples."""

    d: np.ndarray
    block: int
    dt: float
    n: int


def block_sums(y: np.ndarray, dt: float, max_blocks: int = MAX_BLOCKS) -> BlockSums:
    """:class:`BlockSums` of one axis (NaN interpolated); InputError below :data:`MIN_BLOCKS` blocks."""
    y = interpolate_missing(np.asarray(y, dtype=float))
    block = max(1, math.ceil(y.size / max_blocks))
    m = y.size // block
    if m < MIN_BLOCKS:
        raise InputError(f"block sums: {y.size} samples make {m} blocks, fewer than {MIN_BLOCKS}")
    sums = y[: m * block].reshape(m, block).sum(axis=1)
    d = np.diff(sums)
    return BlockSums(d - d.mean(), block, float(dt), int(y.size))


def sum_lags(block: int, lags: int) -> np.ndarray:
    """The lags [samples] at which γ_D(0 … lags − 1) reads K: (−2 … lags + 1)·L."""
    return np.arange(-2, lags + 2, dtype=float) * block


def from_sum_covariance(k: np.ndarray) -> np.ndarray:
    """γ_D(h) from K at :func:`sum_lags` (the filter [1, −4, 6, −4, 1] of the module docstring), along the last
    axis."""
    return k[..., :-4] - 4.0 * k[..., 1:-3] + 6.0 * k[..., 2:-2] - 4.0 * k[..., 3:-1] + k[..., 4:]


def autocovariance(components: list[Component], block: int, dt: float, lags: int) -> np.ndarray:
    """γ_D(h), h = 0 … lags − 1, of the differences of block sums of ``block`` samples (module docstring)."""
    h = sum_lags(block, lags)
    return from_sum_covariance(np.sum([c.sum_covariance(h, dt) for c in components], axis=0))


def toeplitz_loglik(gamma: np.ndarray, x: np.ndarray) -> float:
    """Exact Gaussian log-likelihood of the zero-mean stationary series ``x`` with autocovariance ``gamma`` (same
    length), from the Cholesky factor of its Toeplitz covariance; −inf where that is not positive definite."""
    try:
        factor = cholesky(toeplitz(gamma), lower=True, check_finite=False)
    except np.linalg.LinAlgError:
        return -math.inf
    z = solve_triangular(factor, x, lower=True, check_finite=False)
    return -0.5 * (2.0 * float(np.log(np.diag(factor)).sum()) + float(z @ z) + x.size * math.log(2.0 * math.pi))


def toeplitz_loglik_and_gradient(gamma: np.ndarray, x: np.ndarray) -> tuple[float, np.ndarray] | None:
    """:func:`toeplitz_loglik` and its gradient in ``gamma``: ∂ℓ/∂γ(h) = ½ tr[(Σ⁻¹xxᵀΣ⁻¹ − Σ⁻¹) T_h], T_h the
    symmetric Toeplitz basis matrix of lag h (ones where |i − j| = h); None where Σ is not positive definite.

    The trace is a sum along the lag-h diagonals: of αα (α = Σ⁻¹x) the autocorrelation of α, of Σ⁻¹ by the
    Gohberg–Semencul formula Σ⁻¹ = (L(c)L(c)ᵀ − L(ĉ)L(ĉ)ᵀ)/c₀, c = Σ⁻¹e₁ the inverse's first column,
    ĉ = (0, c_{M−1}, …, c₁), L(v) the lower triangular Toeplitz matrix with first column v (I. Gohberg, A. Semencul,
    Mat. Issled. 7, 1972), whose lag-h diagonal of L(v)L(v)ᵀ sums to :func:`_weighted_autocorrelation`: O(M²) after
    the Cholesky factor instead of forming Σ⁻¹ (O(M³))."""
    try:
        factor = cho_factor(toeplitz(gamma), lower=True, check_finite=False)
    except np.linalg.LinAlgError:
        return None
    m = x.size
    alpha = cho_solve(factor, x, check_finite=False)
    unit = np.zeros(m)
    unit[0] = 1.0
    first = cho_solve(factor, unit, check_finite=False)
    ll = -0.5 * (2.0 * float(np.log(np.diag(factor[0])).sum()) + float(x @ alpha) + m * math.log(2.0 * math.pi))
    shifted = np.concatenate([[0.0], first[:0:-1]])
    inverse_sums = (_weighted_autocorrelation(first) - _weighted_autocorrelation(shifted)) / first[0]
    sums = np.correlate(alpha, alpha, "full")[m - 1:] - inverse_sums
    sums[1:] *= 2.0  # the lag-h diagonal above and below
    return ll, 0.5 * sums


def _weighted_autocorrelation(v: np.ndarray) -> np.ndarray:
    """Σ_{l=0}^{M−1−h} (M − h − l) v_l v_{l+h} for h = 0 … M − 1: the sum of the lag-h diagonal of L(v)L(v)ᵀ."""
    m = v.size
    lagged = np.correlate(v, v, "full")[m - 1:]
    weighted = np.correlate(v, np.arange(m) * v, "full")[m - 1:]
    return (m - np.arange(m)) * lagged - weighted


def loglik(components: list[Component], sums: BlockSums) -> float:
    """Exact log-likelihood of the block sums' differences under ``components``."""
    return toeplitz_loglik(autocovariance(components, sums.block, sums.dt, sums.d.size), sums.d)


def fit(start: list[Component], sums: BlockSums) -> tuple[float, list[Component]]:
    """(log-likelihood, components) maximised over :data:`SLOW_TYPES`' log-parameters (GM τ ∈ [dt/2, 100 records])."""
    keys = [(i, name) for i, c in enumerate(start) if isinstance(c, SLOW_TYPES) for name in c.parameter_names]
    lags = sum_lags(sums.block, sums.d.size)
    held_k = sum((c.sum_covariance(lags, sums.dt) for c in start if not isinstance(c, SLOW_TYPES)), np.zeros(lags.size))
    x0 = np.log([start[i].params()[name] for i, name in keys])
    tau_range = (math.log(sums.dt / 2.0), math.log(100.0 * sums.n * sums.dt))
    box = [tau_range if name == "tau" else (v - 30.0, v + 30.0) for (_, name), v in zip(keys, x0, strict=True)]
    x0 = np.clip(x0, [b[0] for b in box], [b[1] for b in box])

    def negll(x: np.ndarray) -> float:
        try:
            comps = with_log_parameters(start, keys, x)
        except ValueError:
            return 1e300
        k = held_k + sum(c.sum_covariance(lags, sums.dt) for c in comps if isinstance(c, SLOW_TYPES))
        ll = toeplitz_loglik(from_sum_covariance(k), sums.d)
        return -ll if math.isfinite(ll) else 1e300

    if not keys:
        return -negll(x0), list(start)
    res = minimize(negll, x0, method="L-BFGS-B", bounds=box, options={"maxiter": 200})
    best = res.x if res.fun <= negll(x0) else x0
    return -float(negll(best)), with_log_parameters(start, keys, best)
