"""Allan variance of a *sampled* stationary process whose autocovariance is a sum of damped exponentials.

The Allan variance an estimator reads from data is that of the samples y_k = x(k·dt) averaged over m samples,
not that of the continuous process averaged over τ = m·dt. The two agree when the process's memory is many
samples long; for the sensor's own low-pass filter (memory of one or two samples) or a fast GM they differ by tens
of per cent at the shortest τ, which the closed loop would read as a misfit. Beyond papers 000/002.

With R(j) = Re(c·z^j) the autocovariance at lag j samples (z = e^{s·dt}; a GM: c = σ², s = −1/τ; an OSC:
c = σ²(1 − i a/ω_d), s = −a + iω_d), the variance of a sum of m consecutive samples is

    S(m) = Re(c·(m + 2 g(m))),     g(m) = Σ_{j=1}^{m−1} (m − j) z^j = z (m(1 − z) − (1 − z^m)) / (1 − z)²,

adjacent block sums A, B have Cov(A, B) = (S(2m) − 2S(m))/2, and the Allan variance of the block means is

    AV(m·dt) = ½ Var(B/m − A/m) = (4 S(m) − S(2m)) / (2 m²)

(the discrete counterpart of AV(τ) = (4Ψ(τ) − Ψ(2τ))/(2τ²)). Where m|s·dt| is small, g(m) is evaluated from its
series m(m−1)/2 + w(m³ − m)/6 + w² m²(m² − 1)/24 (w = s·dt), which avoids the cancellation of the closed form.
"""

from __future__ import annotations

import numpy as np

#: Below this m·|s·dt| the series of g(m) is used (its truncation error is ≈ (m|w|)³ relative).
SERIES_LIMIT = 1e-3


def _expm1(w: np.ndarray) -> np.ndarray:
    """e^w − 1 for complex w without cancellation near 0."""
    small = np.abs(w) < 1e-5
    with np.errstate(over="ignore", invalid="ignore"):
        direct = np.exp(w) - 1.0
    return np.where(small, w + w * w / 2.0 + w * w * w / 6.0, direct)


def _g(m: np.ndarray, w: np.ndarray) -> np.ndarray:
    """g(m) = Σ_{j=1}^{m−1} (m − j) e^{jw} (module docstring), closed form or series; ``w`` broadcasts against m."""
    w = np.asarray(w, dtype=complex)
    one_minus_z = -_expm1(np.broadcast_to(w, np.broadcast_shapes(m.shape, w.shape)))
    one_minus_zm = -_expm1(m * w)
    z = 1.0 - one_minus_z
    with np.errstate(divide="ignore", invalid="ignore"):
        closed = z * (m * one_minus_z - one_minus_zm) / one_minus_z**2
    series = m * (m - 1.0) / 2.0 + w * (m**3 - m) / 6.0 + w * w * m * m * (m * m - 1.0) / 24.0
    return np.where(np.abs(m * w) < SERIES_LIMIT, series, closed)


def sampled_allan_variance(c: complex | np.ndarray, s: complex | np.ndarray, tau: np.ndarray,
                           dt: float) -> np.ndarray:
    """AV [u²] at ``tau`` [s] of the process sampled at ``dt`` [s] with R(u) = Re(c e^{s u}) (module docstring).

    Parameters
    ----------
    c : complex, or (k,) array
        Autocovariance weight [u²] (R(0) = Re c is the variance).
    s : complex, or (k,) array
        Pole [1/s], Re s < 0. With arrays, the AV of the sum of the k processes (a flicker ladder) in one pass.
    tau : array
        Averaging times [s]; τ/dt is the number of samples averaged (integers for estimator τ).
    dt : float
        Sampling period [s].
    """
    m = np.asarray(tau, dtype=float) / dt
    c = np.asarray(c, dtype=complex)
    w = np.asarray(s, dtype=complex) * dt
    if c.ndim:  # one row per process, summed
        m, c, w = m[None, ...], c.reshape(-1, *([1] * m.ndim)), w.reshape(-1, *([1] * m.ndim))

    def block_sum_variance(k: np.ndarray) -> np.ndarray:
        v = np.real(c * (k + 2.0 * _g(k, w)))
        return v.sum(axis=0) if c.ndim else v

    m_tau = np.asarray(tau, dtype=float) / dt
    return (4.0 * block_sum_variance(m) - block_sum_variance(2.0 * m)) / (2.0 * m_tau * m_tau)


def block_sum_variance(c: complex, s: complex, k: np.ndarray, dt: float) -> np.ndarray:
    """S(k) = Var(y_1 + … + y_k) [u²] of the process sampled at ``dt`` [s] with R(u) = Re(c e^{s u}), for sample
    counts k ≥ 0 (module docstring; S(0) = 0), as the generalised covariance of the partial sums needs it
    (:meth:`~imu_noise_id.core.noise.base.Component.sum_covariance`). A real pole (GM, LPF) is evaluated in real
    arithmetic (several times faster on the long lag grids of the wavelet-variance covariance; equal to rounding)."""
    k = np.asarray(k, dtype=float)
    w = complex(s) * dt
    if w.imag == 0.0 and complex(c).imag == 0.0:
        return complex(c).real * (k + 2.0 * _g_real(k, w.real))
    return np.real(complex(c) * (k + 2.0 * _g(k, w)))


def _g_real(m: np.ndarray, w: float) -> np.ndarray:
    """:func:`_g` for a real w < 0."""
    mw = m * w
    one_minus_z = -_expm1(np.asarray(w))
    closed = (1.0 - one_minus_z) * (m * one_minus_z + _expm1(mw)) / one_minus_z**2
    small = np.abs(mw) < SERIES_LIMIT
    if not np.any(small):
        return closed
    series = m * (m - 1.0) / 2.0 + w * (m**3 - m) / 6.0 + w * w * m * m * (m * m - 1.0) / 24.0
    return np.where(small, series, closed)
