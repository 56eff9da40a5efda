"""Closed-form shape derivatives of the fixed-size likelihoods' statistics for components whose autocovariance is a sum
of damped exponentials (core/estimation/em/exponential_parts.py), against the statistics themselves."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imu_noise_id.core.estimation.em import block_sums, composite, exponential_parts, whittle
from imu_noise_id.core.noise.components import GM, RW, WN, simulate_sum
from imu_noise_id.core.noise.digital import DLPF
from imu_noise_id.core.noise.flicker import BI
from imu_noise_id.core.noise.resonant import LPF, MAX_DAMPING, OSC

DT = 0.01
SHAPED = [GM(tau=3.0, sigma=1.5e-3), GM(tau=2e4, sigma=1e-3), LPF(1e-3, 8.0), OSC(frequency=0.5, bandwidth=0.03,
          sigma=5e-4), OSC(frequency=12.0, bandwidth=4.0, sigma=1e-3), OSC(frequency=0.05, bandwidth=1e-4, sigma=1e-3)]


def _moved(component, name: str, h: float):
    return type(component)(**{**component.params(), name: component.params()[name] * math.exp(h)})


@pytest.mark.parametrize("w", [-1e-7, -3e-5, -1e-6 + 1e-5j, -1e-4 + 0.03j, -1e-3, -0.01 + 0.5j, -0.2, -1.0 + 2.0j])
def test_the_block_sums_factor_derivative_is_the_lag_weighted_sum_of_its_lags(w):
    """g'(m) = Σ_{j<m} j (m − j) e^{jw}, summed directly, on both sides of the series limit."""
    lags = np.array([0.0, 1.0, 2.0, 3.0, 7.0, 40.0, 100.0, 500.0, 2000.0, 20000.0])
    _, derivative = exponential_parts.sum_covariance_factor(np.array([w]), lags)
    for m, d in zip(lags.astype(int), derivative[0], strict=True):
        j = np.arange(1, m, dtype=float)
        direct = complex(np.sum(j * (m - j) * np.exp(j * w)))
        assert abs(-d - direct) <= 1e-8 * abs(direct) + 1e-12, m


@pytest.mark.parametrize("component", SHAPED, ids=repr)
def test_the_factors_give_the_statistics_of_the_component(component):
    omega = np.linspace(0.01, math.pi - 0.01, 300)
    lags = block_sums.sum_lags(64, 20)
    c, s = (np.asarray(v, dtype=complex) for v in component.exponential_terms())
    spectrum = np.real(np.sum(c[:, None] * exponential_parts.difference_spectrum_factor(s * DT, omega)[0], axis=0))
    assert spectrum == pytest.approx(whittle.difference_spectrum([component], omega, DT), rel=1e-9)
    sums = np.real(np.sum(c[:, None] * exponential_parts.sum_covariance_factor(s * DT, lags)[0], axis=0))
    assert sums == pytest.approx(component.sum_covariance(lags, DT), rel=1e-9, abs=1e-12 * np.max(np.abs(sums)))


def _closed(components, omega, lags):
    """closed_parts of both statistics, split back into (spectrum, sums) per component."""
    shares, shapes = exponential_parts.closed_parts(components, DT, [
        lambda w: exponential_parts.difference_spectrum_factor(w, omega),
        lambda w: exponential_parts.sum_covariance_factor(w, lags)], lambda arrays: np.concatenate(arrays, axis=-1))
    n = omega.size
    return ({i: (v[:n], v[n:]) for i, v in shares.items()},
            {i: {name: (d[:n], d[n:]) for name, d in by_name.items()} for i, by_name in shapes.items()})


@pytest.mark.parametrize("component", SHAPED, ids=repr)
def test_the_shape_derivatives_are_those_of_the_statistics(component):
    """Against central differences of the statistics themselves (the rule they replace), every shape parameter; the
    component stacked between others, whose terms must not leak into its rows."""
    omega = np.linspace(0.005, math.pi - 0.005, 500)
    lags = block_sums.sum_lags(64, 30)
    others = [GM(tau=0.7, sigma=2e-3), OSC(frequency=3.0, bandwidth=0.2, sigma=1e-3)]
    shares, shapes = _closed([others[0], WN(1e-3), component, others[1]], omega, lags)
    assert sorted(shares) == sorted(shapes) == [0, 2, 3]
    assert shares[2][0] == pytest.approx(whittle.difference_spectrum([component], omega, DT), rel=1e-9)
    k = component.sum_covariance(lags, DT)
    assert shares[2][1] == pytest.approx(k, rel=1e-9, abs=1e-12 * np.max(np.abs(k)))
    names = [n for n in component.parameter_names if n != component.scale_name]
    assert sorted(shapes[2]) == sorted(names)
    spectrum, sums = ({n: d[0] for n, d in shapes[2].items()}, {n: d[1] for n, d in shapes[2].items()})
    for name in names:
        h = 1e-5
        up, down = _moved(component, name, h), _moved(component, name, -h)
        d_spectrum = (whittle.difference_spectrum([up], omega, DT) - whittle.difference_spectrum([down], omega, DT)) / (
            2 * h)
        d_sums = (up.sum_covariance(lags, DT) - down.sum_covariance(lags, DT)) / (2 * h)
        assert spectrum[name] == pytest.approx(d_spectrum, rel=1e-5, abs=1e-6 * np.max(np.abs(d_spectrum))), name
        assert sums[name] == pytest.approx(d_sums, rel=1e-5, abs=1e-6 * np.max(np.abs(d_sums))), name


def test_components_without_exponential_terms_or_shape_have_no_closed_form():
    omega = np.linspace(0.01, 3.0, 50)
    closed = whittle.spectrum_parts(omega, DT).closed
    assert closed([DLPF(1e-3, 5.0, 2), BI(5e-5, 1.0, 300.0), WN(1e-3)]) == ({}, {})


@pytest.mark.parametrize("component", SHAPED, ids=repr)
def test_the_terms_closed_derivatives_are_their_differences(component):
    """exponential_term_derivatives against central differences of exponential_terms, every shape parameter."""
    closed = component.exponential_term_derivatives()
    names = [n for n in component.parameter_names if n != component.scale_name]
    assert sorted(closed) == sorted(names)
    for name in names:
        h = 1e-6
        (c_up, s_up), (c_down, s_down) = (_moved(component, name, step).exponential_terms() for step in (h, -h))
        dc, ds = closed[name]
        assert np.abs(dc - (c_up - c_down) / (2 * h)) <= 1e-6 * np.abs(c_up) + 1e-300, name
        assert np.abs(ds - (s_up - s_down) / (2 * h)) <= 1e-6 * np.abs(s_up), name


def test_at_the_damping_limit_the_closed_form_is_the_derivative_from_inside():
    # a wider line is refused there; the closed form is the limit of the one-sided differences of the statistics
    edge = OSC(frequency=1.0, bandwidth=2.0 * MAX_DAMPING * (1.0 - 1e-9), sigma=1e-3)
    with pytest.raises(ValueError):
        _moved(edge, "bandwidth", 1e-6)
    omega = np.linspace(0.01, math.pi - 0.01, 200)
    spectrum = whittle.spectrum_parts(omega, DT).closed([edge])[1][0]["bandwidth"]
    inside = [whittle.difference_spectrum([_moved(edge, "bandwidth", -h)], omega, DT) for h in (1e-5, 2e-5)]
    one_sided = (3 * whittle.difference_spectrum([edge], omega, DT) - 4 * inside[0] + inside[1]) / (2 * 1e-5)
    assert spectrum == pytest.approx(one_sided, rel=1e-5, abs=1e-6 * np.max(np.abs(one_sided)))


def test_the_whittle_and_composite_gradients_agree_with_and_without_the_closed_forms():
    y = simulate_sum([WN(2e-3), GM(tau=5.0, sigma=2e-3), RW(2e-5)], 300_000, DT, np.random.default_rng(3))
    stats = composite.CompositeStatistics.of(y, DT)
    start = [WN(2.5e-3), LPF(1e-3, 8.0), GM(tau=3.0, sigma=1.5e-3), OSC(frequency=0.5, bandwidth=0.03, sigma=5e-4),
             RW(3e-5)]
    bp = stats.bands(start)
    keys = [(i, k) for i, c in enumerate(start) for k in c.parameter_names]
    x = np.log([start[i].params()[k] for i, k in keys])
    closed = composite.statistics_parts(stats, bp)
    plain = whittle.ComponentParts(closed.computed)
    ll, grad = composite.loglik_and_gradient(start, keys, x, stats, bp, parts=closed)
    ll_plain, grad_plain = composite.loglik_and_gradient(start, keys, x, stats, bp, parts=plain)
    assert ll == pytest.approx(ll_plain, rel=1e-13)
    assert grad == pytest.approx(grad_plain, rel=1e-4, abs=1e-3)
    spectrum_parts = whittle.spectrum_parts(bp.omega, DT)
    _, grad_w = whittle.loglik_and_gradient(start, keys, x, bp, spectrum_parts)
    _, grad_w_plain = whittle.loglik_and_gradient(start, keys, x, bp, whittle.ComponentParts(spectrum_parts.computed))
    assert grad_w == pytest.approx(grad_w_plain, rel=1e-4, abs=1e-3)


def _difference_spectrum_factor_long(w: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(F, ∂F/∂w) of the module docstring evaluated as written, in long double (the reference's rounding far below the
    float64 one's)."""
    w = np.asarray(w, dtype=np.clongdouble)[:, None]
    omega = np.asarray(omega, dtype=np.longdouble)[None, :]
    z = np.exp(w)
    denominator = np.expm1(w + 1j * omega) * np.expm1(w - 1j * omega)
    differencing = 4.0 * np.sin(omega / 2.0) ** 2
    f = differencing * -np.expm1(2.0 * w) / denominator
    return f, differencing * 2.0 * z * (np.expm1(w) ** 2 * np.cos(omega) - differencing * z) / denominator**2


def test_the_difference_spectrum_factor_keeps_float64_accuracy_at_its_poles_frequencies():
    """Slow, fast and narrow poles on a grid holding each narrow pole's own frequency and points 1e-9 and 1e-7
    (relative) beside it, where 1 − z e^{±iω} nearly cancels: F and ∂F/∂w within 1e-13 of the long-double reference
    (the inputs' own rounding gives ~1e-16; the sum form without its expm1 there, ~1e-10)."""
    poles = np.array([-1e-6, -3e-4, -0.05, -0.5, -2e-7 + 0.3j, -2e-7 - 0.3j, -1e-4 + 1.2j, -1e-4 - 1.2j,
                      -0.3 + 2.5j, -0.3 - 2.5j])
    lines = np.abs(poles.imag[poles.imag > 0])
    omega = np.sort(np.concatenate([np.linspace(1e-5, math.pi, 400), lines, lines * (1 + 1e-9), lines * (1 - 1e-7)]))
    f, df = exponential_parts.difference_spectrum_factor(poles, omega)
    f_ref, df_ref = _difference_spectrum_factor_long(poles, omega)
    assert np.max(np.abs(f - f_ref) / np.abs(f_ref)) < 1e-13
    # ∂F/∂w vanishes on a curve through the grid: relative to its size along each pole's row there
    assert np.max(np.abs(df - df_ref) / np.max(np.abs(df_ref), axis=1, keepdims=True)) < 1e-13
