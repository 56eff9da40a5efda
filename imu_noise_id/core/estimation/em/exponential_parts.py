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
∂w_k/∂ϑ], the scalars' derivatives in closed form from the component
(:meth:`~...noise.base.Component.exponential_term_derivatives`). The shares themselves are
Re Σ c_k F(w_k) too: :func:`closed_parts` stacks every component's terms and evaluates each statistic's (F, ∂F/∂w)
once for all of them, the shares and their derivatives then two matrix products (not a dozen small array operations
per component and evaluation). Beyond the papers.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ...noise.base import Component
from ...noise.sampled import EXPM1_BELOW, SERIES_LIMIT, lag_weighted_sum

#: Per parameter name, (∂c/∂ln ϑ, ∂w/∂ln ϑ) of the exponential terms.
TermDerivatives = dict[str, tuple[np.ndarray, np.ndarray]]


def term_derivatives(component: Component, dt: float) -> tuple[np.ndarray, np.ndarray, TermDerivatives] | None:
    """(c, w, {name: (∂c/∂ln ϑ, ∂w/∂ln ϑ)}) of ``component``'s exponential terms (c [u²], w = s·dt) for each shape
    parameter (:meth:`~...noise.base.Component.exponential_term_derivatives`); None where it has no such terms or
    their derivatives are not in closed form."""
    terms = component.exponential_terms()
    closed = component.exponential_term_derivatives() if terms is not None else None
    if closed is None:
        return None
    c, s = (np.asarray(v, dtype=complex) for v in terms)
    return c, s * dt, {name: (np.asarray(dc, dtype=complex), np.asarray(ds, dtype=complex) * dt)
                       for name, (dc, ds) in closed.items()}


def _one_less_turned(one_minus_z: np.ndarray, z: np.ndarray, w: np.ndarray, omega: np.ndarray,
                     sign: float) -> np.ndarray:
    """1 − z e^{±iω} (k, n) for z = e^w (k, 1) at ``omega`` (n,), ``sign`` ±1, as (1 − z) + z(1 − e^{±iω}): products
    only. Its rounding error is ~ε(|w| + ω), relative ε(|w| + ω)/|w ± iω|: a real w never cancels ±iω, a complex one
    does near ω = ∓Im w; where the sum is below :data:`~...noise.sampled.EXPM1_BELOW` of its terms' size there, it is
    −expm1(w ± iω) instead (the digits the sum lost)."""
    turn = -np.expm1(sign * 1j * omega)
    out = one_minus_z + z * turn
    complex_rows = np.flatnonzero(w[:, 0].imag != 0.0)
    if complex_rows.size:
        size = np.abs(one_minus_z[complex_rows]) + np.abs(turn)
        rows, cols = np.nonzero(np.abs(out[complex_rows]) < EXPM1_BELOW * size)
        rows = complex_rows[rows]
        out[rows, cols] = -np.expm1(w[rows, 0] + sign * 1j * omega[cols])
    return out


def difference_spectrum_factor(w: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(F, ∂F/∂w) of the differences' spectrum (module docstring) for terms ``w`` (k,) at ``omega`` (n,) [rad/sample]:
    arrays (k, n), each factor computed without cancellation (expm1) for z near 1 and for z e^{±iω} near 1. The
    denominator's two factors are products of per-term and per-frequency exponentials (:func:`_one_less_turned`,
    not k·n complex exponentials) and divided by once."""
    w = np.asarray(w, dtype=complex)[:, None]
    omega = np.asarray(omega, dtype=float)
    one_minus_z = -np.expm1(w)
    z = 1.0 - one_minus_z
    inverse = 1.0 / (_one_less_turned(one_minus_z, z, w, omega, 1.0)
                     * _one_less_turned(one_minus_z, z, w, omega, -1.0))  # 1/((1 − z e^{iω})(1 − z e^{−iω}))
    half = np.sin(omega / 2.0) ** 2
    differencing = 4.0 * half  # 2 − 2 cos ω
    f = (-np.expm1(2.0 * w) * differencing) * inverse
    numerator = 2.0 * z * (one_minus_z**2 * np.cos(omega) - 4.0 * z * half)
    return f, (numerator * differencing) * inverse * inverse


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


#: A statistic's (F, ∂F/∂w) for the terms' w (k,): e.g. :func:`difference_spectrum_factor` at given frequencies.
Factor = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


@dataclass(frozen=True)
class StackedTerms:
    """The exponential terms of several components side by side, so that each statistic's factor is evaluated once
    for all of them: row r of ``values`` holds c_k [u²] on the terms of component ``owners[r]`` (0 elsewhere); row r
    of ``d_c`` and ``d_w`` holds ∂c_k/∂ln ϑ and c_k·∂w_k/∂ln ϑ of ``shapes[r]`` = (component index, parameter name)
    on its component's terms; ``w`` the terms' s·dt (k,)."""

    owners: tuple[int, ...]
    values: np.ndarray
    shapes: tuple[tuple[int, str], ...]
    d_c: np.ndarray
    d_w: np.ndarray
    w: np.ndarray

    @classmethod
    def of(cls, components: list[Component], dt: float) -> StackedTerms | None:
        """The terms of those ``components`` with a shape parameter and exponential terms whose derivatives are in
        closed form (:func:`term_derivatives`); None where there are none."""
        found = []
        for i, component in enumerate(components):
            if component.scale_only() is None:  # a scale-only share is computed once per shape and rescaled
                terms = term_derivatives(component, dt)
                if terms is not None:
                    found.append((i, terms))
        if not found:
            return None
        sizes = [c.size for _, (c, _, _) in found]
        offsets = np.concatenate([[0], np.cumsum(sizes)])
        values = np.zeros((len(found), offsets[-1]), dtype=complex)
        rows_c, rows_w, shapes = [], [], []
        for r, (i, (c, _, moved)) in enumerate(found):
            span = slice(offsets[r], offsets[r + 1])
            values[r, span] = c
            for name, (dc, dw) in moved.items():
                row_c, row_w = np.zeros(offsets[-1], dtype=complex), np.zeros(offsets[-1], dtype=complex)
                row_c[span], row_w[span] = dc, c * dw
                rows_c.append(row_c)
                rows_w.append(row_w)
                shapes.append((i, name))
        width = offsets[-1]
        return cls(tuple(i for i, _ in found), values, tuple(shapes), np.array(rows_c).reshape(-1, width),
                   np.array(rows_w).reshape(-1, width), np.concatenate([w for _, (_, w, _) in found]))

    def evaluate(self, factor: Factor) -> tuple[np.ndarray, np.ndarray]:
        """(each owner's share Re Σ_k c_k F(w_k), (owners, n); each shape's ∂/∂ln ϑ of it, (shapes, n)) of one
        statistic (module docstring)."""
        f, df = factor(self.w)
        return np.real(self.values @ f), np.real(self.d_c @ f + self.d_w @ df)


#: Per component index, its share of a likelihood's statistics, and its ∂share/∂ln ϑ per shape parameter name.
ClosedParts = tuple[dict[int, np.ndarray], dict[int, dict[str, np.ndarray]]]


def closed_parts(components: list[Component], dt: float, factors: list[Factor],
                 combine: Callable[[list[np.ndarray]], np.ndarray]) -> ClosedParts:
    """({component index: its share}, {component index: {shape parameter name: ∂share/∂ln ϑ}}) of those
    ``components`` :meth:`StackedTerms.of` takes, each share the per-statistic arrays of ``factors`` joined by
    ``combine`` along their last axis (e.g. concatenated); both empty where none has such terms."""
    terms = StackedTerms.of(components, dt)
    if terms is None:
        return {}, {}
    evaluated = [terms.evaluate(factor) for factor in factors]
    shares = combine([share for share, _ in evaluated])
    derivatives = combine([d for _, d in evaluated])
    by_shape: dict[int, dict[str, np.ndarray]] = {}
    for (i, name), d in zip(terms.shapes, derivatives, strict=True):
        by_shape.setdefault(i, {})[name] = d
    return dict(zip(terms.owners, shares, strict=True)), by_shape
