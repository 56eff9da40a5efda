"""AV of a sampled stationary process whose autocovariance is a sum of damped exponentials (docs/noise.md): R(j) =
Re(c·z^j), z = e^{s·dt} (GM: c = σ², s = −1/τ; OSC: c = σ²(1 − ia/ω_d), s = −a + iω_d), S(m) = Re(c·(m + 2 g(m))),
g(m) = z (m(1 − z) − (1 − z^m))/(1 − z)², AV(m·dt) = (4 S(m) − S(2m))/(2m²); g by its series where m|w| <
:data:`SERIES_LIMIT` (w = s·dt)."""

from __future__ import annotations

import math

import numpy as np

#: Below this m·|s·dt| the series of g(m) is used (its truncation error is ≈ (m|w|)³ relative).
SERIES_LIMIT = 1e-3
#: Below this |x| :func:`complex_expm1` calls numpy's expm1; above it e^x − 1 loses no more than a digit to the
#: subtraction.
EXPM1_BELOW = 0.1


def complex_expm1(x: np.ndarray) -> np.ndarray:
    """e^x − 1 of a complex array, accurate near 0: numpy's expm1 where |x| < :data:`EXPM1_BELOW`, elsewhere exp less
    1 (numpy's complex expm1 takes twice the time of its exp)."""
    x = np.asarray(x, dtype=complex)
    if x.ndim == 0:
        return np.expm1(x)
    out = np.exp(x)
    out -= 1.0
    near = np.abs(x) < EXPM1_BELOW
    if near.any():
        out[near] = np.expm1(x[near])
    return out


def _series(m: np.ndarray, w: np.ndarray) -> np.ndarray:
    """g(m) from its series in w, m·|w| < :data:`SERIES_LIMIT`."""
    return m * (m - 1.0) / 2.0 + w * (m**3 - m) / 6.0 + w * w * m * m * (m * m - 1.0) / 24.0


def lag_weighted_sum(m: np.ndarray, w: np.ndarray) -> np.ndarray:
    """g(m) = Σ_{j=1}^{m−1} (m − j) e^{jw}, closed form or series; ``w`` broadcasts against m."""
    w = np.asarray(w, dtype=complex)
    one_minus_z = -np.expm1(w)  # per pole; broadcast against m below
    mw = m * w
    with np.errstate(divide="ignore", invalid="ignore"):
        closed = (1.0 - one_minus_z) * (m * one_minus_z + complex_expm1(mw)) / one_minus_z**2
    return _series_where_small(closed, m, w, mw)


def _series_where_small(closed: np.ndarray, m: np.ndarray, w: np.ndarray | float, mw: np.ndarray) -> np.ndarray:
    small = np.abs(mw) < SERIES_LIMIT
    if not small.any():
        return closed
    out = np.array(np.broadcast_to(closed, mw.shape))
    out[small] = _series(np.broadcast_to(m, mw.shape)[small], np.broadcast_to(w, mw.shape)[small])
    return out


def sampled_allan_variance(c: complex | np.ndarray, s: complex | np.ndarray, tau: np.ndarray,
                           dt: float) -> np.ndarray:
    """AV [u²] at ``tau`` [s] of the process sampled at ``dt`` [s] with R(u) = Re(c e^{su}), c [u²], Re s < 0 [1/s];
    arrays (k,): the sum of k processes."""
    m = np.asarray(tau, dtype=float) / dt
    c = np.asarray(c, dtype=complex)
    if c.ndim:  # one row per process, summed; real poles (a flicker ladder) in real arithmetic
        w = np.asarray(s, dtype=complex).reshape(-1, *([1] * m.ndim)) * dt
        c = c.reshape(-1, *([1] * m.ndim))
        real = not (w.imag.any() or c.imag.any())

        def sums(k: np.ndarray) -> np.ndarray:
            if real:
                return real_poles_sum_variance(c.real.ravel(), np.real(np.ravel(s)), k, dt)
            return np.real(c * (k + 2.0 * lag_weighted_sum(k, w))).sum(axis=0)
    else:
        def sums(k: np.ndarray) -> np.ndarray:
            return block_sum_variance(complex(c), complex(s), k, dt)

    return (4.0 * sums(m) - sums(2.0 * m)) / (2.0 * m * m)


def zero_frequency_psd(c: complex, s: complex, dt: float) -> float:
    """dt·Σ_j R(j) = dt·Re(c (1 + z)/(1 − z)), z = e^{s·dt}: the sampled process's two-sided PSD [u²/Hz] at 0 Hz."""
    z = np.exp(complex(s) * dt)
    return float(dt * np.real(complex(c) * (1.0 + z) / (1.0 - z)))


def block_sum_variance(c: complex, s: complex, k: np.ndarray, dt: float) -> np.ndarray:
    """S(k) = Var(y_1 + … + y_k) [u²] for R(u) = Re(c e^{su}), k ≥ 0 (S(0) = 0)."""
    k = np.asarray(k, dtype=float)
    w = complex(s) * dt
    if w.imag == 0.0 and complex(c).imag == 0.0:
        return complex(c).real * (k + 2.0 * _g_real(k, w.real))
    return np.real(complex(c) * (k + 2.0 * lag_weighted_sum(k, w)))


def consecutive_powers(w: complex, size: int) -> np.ndarray:
    """e^{kw} for k = 0 … size − 1: products e^{qBw}·e^{rw} (k = qB + r, B = ⌊√size⌋) of about 2√size exponentials,
    each a few ulp (not size complex exponentials)."""
    block = max(1, math.isqrt(size))
    inner = np.exp(np.arange(block) * w)
    outer = np.exp(np.arange(0, size, block) * w)
    return np.multiply.outer(outer, inner).ravel()[:size]


def consecutive_block_sum_variance(c: complex, s: complex, size: int, dt: float) -> np.ndarray:
    """:func:`block_sum_variance` at k = 0 … size − 1 [u²]. From k₀ = ⌈1/|w|⌉ (w = s·dt, z = e^w) with g split,
    S(k) = k·Re(c(1 + z)/(1 − z)) − 2Re(B) + 2Re(B z^k), B = c z/(1 − z)², z^k by :func:`consecutive_powers`: there
    k|w| ≥ 1 and no part exceeds S's own scale by more than a few times; below k₀ (and for real c and s, whose
    arithmetic is real) as block_sum_variance."""
    c, w = complex(c), complex(s) * dt
    if w.imag == 0.0 and c.imag == 0.0:
        return block_sum_variance(c, s, np.arange(size, dtype=float), dt)
    start = min(size, math.ceil(1.0 / abs(w)))
    out = np.empty(size)
    out[:start] = block_sum_variance(c, s, np.arange(start, dtype=float), dt)
    if start < size:
        one_minus_z = -np.expm1(w)
        z = 1.0 - one_minus_z
        b = c * z / one_minus_z**2
        k = np.arange(start, size, dtype=float)
        out[start:] = k * (c * (1.0 + z) / one_minus_z).real - 2.0 * b.real
        out[start:] += 2.0 * (b * consecutive_powers(w, size - start) * np.exp(start * w)).real
    return out


def real_poles_sum_variance(c: float | np.ndarray, s: np.ndarray, k: np.ndarray, dt: float) -> np.ndarray:
    """Σ_j S_j(k) [u²] over real poles ``s`` [1/s] with weights ``c`` [u²] (one, or one per pole)."""
    k = np.asarray(k, dtype=float)
    rows = (-1, *([1] * k.ndim))
    w = (np.asarray(s, dtype=float) * dt).reshape(rows)
    c = np.asarray(c, dtype=float)
    if c.ndim == 0:
        return float(c) * np.sum(k + 2.0 * _g_real(k, w), axis=0)
    return np.sum(c.reshape(rows) * (k + 2.0 * _g_real(k, w)), axis=0)


def _g_real(m: np.ndarray, w: float | np.ndarray) -> np.ndarray:
    """:func:`lag_weighted_sum` for real w < 0 (a float, or an array broadcasting against m)."""
    mw = m * w
    one_minus_z = -np.expm1(w)
    closed = (1.0 - one_minus_z) * (m * one_minus_z + np.expm1(mw)) / one_minus_z**2
    return _series_where_small(closed, m, w, mw)
