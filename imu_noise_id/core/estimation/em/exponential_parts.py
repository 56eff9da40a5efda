"""Shape derivatives of a component's share of the fixed-size likelihoods' statistics, analytic where its sampled
autocovariance is a sum of damped exponentials R(u) = Re Σ_k c_k e^{s_k u} (GM, LPF, OSC: ``exponential_terms``).

With w = s·dt and z = e^w, each statistic is Re Σ_k c_k F(w_k), F holomorphic in w (docs/noise.md, sampled processes):

* the spectral density per sample of the differences (:func:`.whittle.difference_spectrum`),
  F(w; ω) = (2 − 2 cos ω)(1 − z²)/((1 − z e^{iω})(1 − z e^{−iω})), and
  ∂F/∂w = (2 − 2 cos ω)·2z[(1 − z)² cos ω − 4z sin²(ω/2)]/((1 − z e^{iω})(1 − z e^{−iω}))²;
* the covariance of block sums K(u) = −½ Var(y₁ + … + y_|u|) (:meth:`~...noise.base.Component.sum_covariance`),
  F(w; m) = −½ (m + 2g(m)), g(m) = Σ_{j=1}^{m−1} (m − j) e^{jw} (:func:`~...noise.sampled.lag_weighted_sum`), and
  ∂F/∂w = −g'(m), g'(m) = Σ_{j=1}^{m−1} j (m − j) e^{jw}, in closed form or, where m|w| is small, by its series.

A log-parameter ϑ of the component moves (c_k, w_k) only: ∂/∂ϑ Re Σ c_k F(w_k) = Re Σ [∂c_k/∂ϑ F(w_k) + c_k F'(w_k)
∂w_k/∂ϑ], the scalars' derivatives by central differences of :data:`STEP` (two constructions of the component, where
differencing the statistics themselves costs two evaluations of them per shape parameter). Beyond the papers.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ...noise.base import Component
from ...noise.sampled import SERIES_LIMIT, lag_weighted_sum

#: Step [log-parameter] of the central differences of the exponential terms (c_k, w_k).
STEP = 1e-5
#: Per parameter name, (∂c/∂ln ϑ, ∂w/∂ln ϑ) of the exponential terms.
TermDerivatives = dict[str, tuple[np.ndarray, np.ndarray]]


def term_derivatives(component: Component, dt: float,
                     step: float = STEP) -> tuple[np.ndarray, np.ndarray, TermDerivatives] | None:
    """(c, w, {name: (∂c/∂ln ϑ, ∂w/∂ln ϑ)}) of ``component``'s exponential terms (c [u²], w = s·dt) for each
    parameter but its scale; None where it has no such terms or a step leaves its domain."""
    terms = component.exponential_terms()
    if terms is None:
        return None
    c, s = (np.asarray(v, dtype=complex) for v in terms)
    params = component.params()
    moved = {}
    for name in component.parameter_names:
        if name == component.scale_name:
            continue
        ends = []
        for h in (step, -step):
            try:
                ch, sh = type(component)(**{**params, name: params[name] * math.exp(h)}).exponential_terms()
            except ValueError:
                return None
            ends.append((np.asarray(ch, dtype=complex), np.asarray(sh, dtype=complex)))
        (c_up, s_up), (c_down, s_down) = ends
        moved[name] = ((c_up - c_down) / (2.0 * step), (s_up - s_down) * dt / (2.0 * step))
    return c, s * dt, moved


def difference_spectrum_factor(w: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(F, ∂F/∂w) of the differences' spectrum (module docstring) for terms ``w`` (k,) at ``omega`` (n,) [rad/sample]:
    arrays (k, n), each factor computed without cancellation (expm1) for z near 1."""
    w = np.asarray(w, dtype=complex)[:, None]
    omega = np.asarray(omega, dtype=float)[None, :]
    one_minus_z = -np.expm1(w)
    z = 1.0 - one_minus_z
    denominator = np.expm1(w + 1j * omega) * np.expm1(w - 1j * omega)  # (1 − z e^{iω})(1 − z e^{−iω})
    half = np.sin(omega / 2.0) ** 2
    differencing = 4.0 * half  # 2 − 2 cos ω
    f = differencing * -np.expm1(2.0 * w) / denominator
    numerator = 2.0 * z * (one_minus_z**2 * np.cos(omega) - 4.0 * z * half)
    return f, differencing * numerator / denominator**2


def _g_derivative_series(m: np.ndarray, w: np.ndarray) -> np.ndarray:
    """g'(m) = T₁ + w T₂ + w² T₃/2, T_n = Σ_{j=1}^{m−1} (m − j) jⁿ (error ≈ (m|w|)³ relative)."""
    t1 = (m**3 - m) / 6.0
    t2 = m * m * (m * m - 1.0) / 12.0
    t3 = m * (m * (m - 1.0)) ** 2 / 4.0 - (m - 1.0) * m * (2.0 * m - 1.0) * (3.0 * m * m - 3.0 * m - 1.0) / 30.0
    return t1 + w * t2 + w * w * t3 / 2.0


def sum_covariance_factor(w: np.ndarray, lags: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(F, ∂F/∂w) of the block sums' covariance K (module docstring) for terms ``w`` (k,) at ``lags`` (n,) [samples]:
    arrays (k, n)."""
    w = np.asarray(w, dtype=complex)[:, None]
    m = np.abs(np.asarray(lags, dtype=float))[None, :]
    g = lag_weighted_sum(m, w)
    # g = z(m u − (1 − z^m))/u², u = 1 − z: g' = z dg/dz = z[(m u − 1 + z^m) + z(m z^{m−1} − m)]/u² + 2z²(m u − 1 +
    # z^m)/u³, with 1 − z^m = −expm1(mw)
    u = -np.expm1(w)
    z = 1.0 - u
    mw = m * w
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        inner = m * u + np.expm1(mw)  # m u − (1 − z^m)
        zm = np.exp(mw)
        closed = z * (inner + m * (zm - z)) / u**2 + 2.0 * z * z * inner / u**3
    small = np.abs(mw) < SERIES_LIMIT
    derivative = np.where(small, _g_derivative_series(m, w), closed)
    return -0.5 * (m + 2.0 * g), -derivative


def part_derivatives(c: np.ndarray, moved: TermDerivatives,
                     factor: tuple[np.ndarray, np.ndarray]) -> dict[str, np.ndarray]:
    """∂/∂ln ϑ of Re Σ_k c_k F(w_k) per parameter name of ``moved`` (from :func:`term_derivatives`), ``factor`` the
    (F, ∂F/∂w) of its statistic (k, n)."""
    f, df = factor
    return {name: np.real(np.sum(dc[:, None] * f + c[:, None] * df * dw[:, None], axis=0))
            for name, (dc, dw) in moved.items()}


#: A statistic's (F, ∂F/∂w) for the terms' w (k,): e.g. :func:`difference_spectrum_factor` at given frequencies.
Factor = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


def shape_derivatives(component: Component, dt: float, factors: list[Factor]) -> list[dict[str, np.ndarray]] | None:
    """Per statistic of ``factors``, ∂/∂ln ϑ of ``component``'s share per shape parameter name (module docstring);
    None without exponential terms or where a step leaves the component's domain."""
    terms = term_derivatives(component, dt)
    if terms is None:
        return None
    c, w, moved = terms
    return [part_derivatives(c, moved, factor(w)) for factor in factors]
