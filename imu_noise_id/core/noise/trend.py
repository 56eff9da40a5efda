"""The least-squares slope of a record and its exact variance under a noise model: ω̂ = Σ_k c_k x_k on the partial sums,
c_k = α·(ī, −1, …, −1, ī), α = 1/(dt·S), ī = (N−1)/2, S = N(N² − 1)/12, K(u) the generalised covariances
(:meth:`~.base.Component.sum_covariance`):

    Var ω̂ = α² [ (2ī² + N − 1)·K(0) − 2 Σ_{h=1}^{N−1} h·K(h) + 2 ī²·K(N) ].          (1)
"""

from __future__ import annotations

import math

import numpy as np

from . import units
from .base import Component

#: Lags evaluated per chunk in eq. (1) (bounds the memory).
CHUNK = 1 << 20
#: Beyond this many of a stationary component's longest decay times its K(h) is summed in closed form.
TAIL_DECAYS = 40.0


def ls_slope(y: np.ndarray, dt: float) -> float:
    """Slope [u/s] of the least-squares line through the finite samples y (at times i·dt)."""
    i = np.flatnonzero(np.isfinite(y))
    if i.size < 2:
        return 0.0
    centred, values = i - i.mean(), y[i]
    return float(centred @ (values - values.mean()) / (centred @ centred) / dt)


def _power_sums(m: int) -> tuple[float, float, float]:
    s1 = m * (m + 1) / 2.0
    s2 = m * (m + 1) * (2 * m + 1) / 6.0
    s4 = m * (m + 1) * (2 * m + 1) * (3.0 * m * m + 3 * m - 1) / 30.0
    return s1, s2, s4


def _closed_form(comp: Component, n: int, dt: float) -> tuple[float, float] | None:
    """(Σ_{h=1}^{N−1} h·K(h), K(N)) of a WN, QN, RW or GM in closed form, or None."""
    m = n - 1
    s1, s2, s4 = _power_sums(m)
    p = comp.params()
    if comp.name == "WN":
        sigma2 = units.white_noise_sigma2(p["noise_density"], dt)
        return -0.5 * sigma2 * s2, -0.5 * sigma2 * n
    if comp.name == "QN":
        c = units.quantization_sigma2(p["Q"], dt)
        return -c * s1, -c
    if comp.name == "RW":
        q = units.random_walk_sigma2(p["random_walk"], dt)
        return q * (s4 - s2) / 12.0, q * (float(n) ** 3 - n) / 12.0
    if comp.name == "GM":
        one_minus = -math.expm1(-dt / p["tau"])
        if m * one_minus < 0.2:  # τ beyond ~5 records: the closed form cancels badly there
            return None
        phi = 1.0 - one_minus
        sum_h_phi = phi * (1.0 - (m + 1) * phi**m + m * phi ** (m + 1)) / one_minus**2
        sum_h_g = phi / one_minus**2 * (one_minus * s2 - s1 + sum_h_phi)
        g_n = phi * (n * one_minus - 1.0 + phi**n) / one_minus**2
        sigma2 = p["sigma"] ** 2
        return -0.5 * sigma2 * (s2 + 2.0 * sum_h_g), -0.5 * sigma2 * (n + 2.0 * g_n)
    return None


def _lag_sums(comp: Component, n: int, dt: float) -> tuple[float, float]:
    """(Σ_{h=1}^{N−1} h·K(h), K(N)): lag by lag up to :data:`TAIL_DECAYS` decay times, closed form beyond."""
    m = n - 1
    h0 = int(min(m, max(8, math.ceil(TAIL_DECAYS * comp.memory(dt)[0] / dt))))
    total = 0.0
    for start in range(1, h0 + 1, CHUNK):
        h = np.arange(start, min(start + CHUNK, h0 + 1), dtype=float)
        total += float(h @ comp.sum_covariance(h, dt))
    if h0 == m:
        return total, float(comp.sum_covariance(np.array([float(n)]), dt)[0])
    k_prev, k_0 = (float(v) for v in comp.sum_covariance(np.array([h0 - 1.0, float(h0)]), dt))
    slope = k_0 - k_prev
    s1 = _power_sums(m)[0] - _power_sums(h0)[0]
    s2 = _power_sums(m)[1] - _power_sums(h0)[1]
    return total + (k_0 - h0 * slope) * s1 + slope * s2, k_0 + (n - h0) * slope


def ls_slope_variance(components: list[Component], n: int, dt: float) -> float:
    """Var ω̂ [(u/s)²] of the least-squares slope of n samples at period dt [s] of the sum of ``components`` (eq. 1)."""
    if n < 2:
        return math.inf
    mid = 0.5 * (n - 1)
    alpha = 12.0 / (dt * n * (n * n - 1.0))
    total = 0.0
    for comp in components:
        if comp.name == "RR":
            continue
        sum_hk, k_n = _closed_form(comp, n, dt) or _lag_sums(comp, n, dt)
        k_0 = float(comp.sum_covariance(np.zeros(1), dt)[0])
        total += (2.0 * mid * mid + n - 1.0) * k_0 - 2.0 * sum_hk + 2.0 * mid * mid * k_n
    return max(alpha * alpha * total, 0.0)
