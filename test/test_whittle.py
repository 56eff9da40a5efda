"""The Whittle likelihood's spectra (core.estimation.whittle): a state-space block's spectral density per sample
against the Fourier sum of its autocovariance, written out independently of the code under test."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import solve_discrete_lyapunov

from imu_noise_id.core.estimation.em.mle import LR_DROP_95, physical_bounds
from imu_noise_id.core.estimation.em.model import FitOptions, NoiseModel
from imu_noise_id.core.estimation.em.whittle import (
    ComponentParts,
    banded_periodogram,
    block_spectrum,
    components_loglik,
    difference_spectrum,
    line_windows,
    loglik_and_gradient,
    osc_start_frequencies,
    whittle_fit,
    whittle_information,
    with_log_parameters,
)
from imu_noise_id.core.noise.components import GM, LPF, MA, OSC, RW, WN, simulate_sum
from imu_noise_id.core.noise.flicker import BI
from imu_noise_id.core.noise.resonant import MAX_DAMPING

DT = 0.01


def _spectrum_from_autocovariance(phi, q, h, omega, lags=4000):
    """S(ω) = R(0) + 2 Σ_{j≥1} R(j) cos(ωj), R(j) = h Φ^j P hᵀ, P the stationary covariance."""
    p = solve_discrete_lyapunov(phi, q)
    r, x = [], p @ h
    for _ in range(lags):
        r.append(h @ x)
        x = phi @ x
    r = np.array(r)
    j = np.arange(1, lags)
    return r[0] + 2.0 * np.cos(np.outer(omega, j)) @ r[1:]


@pytest.mark.parametrize("component", [OSC(3.0, 0.6, 1e-3), OSC(20.0, 8.0, 2e-3), MA(1e-3), LPF(1e-3, 20.0),
                                       BI(3e-4, 0.05, 2.0)], ids=str)
def test_block_spectrum_is_the_fourier_sum_of_the_autocovariance(component):
    blk = component.block(DT)
    omega = np.linspace(0.01, np.pi, 57)
    assert block_spectrum(blk.phi, blk.q, blk.h, omega) == pytest.approx(
        _spectrum_from_autocovariance(blk.phi, blk.q, blk.h, omega), rel=1e-6)


def test_a_block_larger_than_two_by_two_is_solved_per_frequency():
    phi = np.array([[0.5, 0.2, 0.0], [-0.1, 0.6, 0.1], [0.0, 0.05, 0.3]])
    q, h = np.diag([1.0, 0.5, 0.2]), np.array([1.0, 0.0, 1.0])
    omega = np.linspace(0.01, np.pi, 31)
    assert block_spectrum(phi, q, h, omega) == pytest.approx(_spectrum_from_autocovariance(phi, q, h, omega), rel=1e-9)


def test_the_finish_reaches_the_maximum_from_a_start_a_decade_off():
    """A refit started away from the maximum (as the loop's are) ends at it. With the observed Whittle Hessian as
    the finish's metric, negative at these starts, the random walk was held at its start and the search stopped
    after one evaluation, 15 and 250 below the maximum."""
    y = simulate_sum([WN(1e-3), RW(2e-5)], 60_000, DT, np.random.default_rng(0))
    model = NoiseModel(y, DT, "WN+RW")
    best = model.fit(None, FitOptions(uncertainty=False)).loglik
    for start in ([WN(1e-5), RW(2e-5)], [WN(1e-4), RW(1e-3)]):
        assert model.fit(start, FitOptions(uncertainty=False)).loglik > best - LR_DROP_95, start


@pytest.mark.parametrize("start", [[WN(1e-4), RW(1e-3)], [WN(1e-3), GM(tau=0.05, sigma=1e-1), RW(1e-6)],
                                   [WN(2e-3), OSC(frequency=0.6, bandwidth=0.2, sigma=1e-4), RW(3e-3)]])
def test_the_whittle_metric_is_positive_semidefinite_at_any_start(start):
    """Its diagonal is what the finish reads as flat (held) or not: never negative for a parameter that matters."""
    y = simulate_sum([WN(2e-3), OSC(frequency=0.5, bandwidth=0.02, sigma=4e-3), RW(3e-4)], 20_000, DT,
                     np.random.default_rng(1))
    info = whittle_information(start, y, DT)
    assert np.allclose(info, info.T)
    assert np.min(np.linalg.eigvalsh(info)) >= -1e-9 * np.max(np.abs(info))


def test_the_whittle_metric_steps_one_sided_at_a_resonance_at_its_damping_limit():
    """The composite likelihood's maximiser can leave a broad resonance at MAX_DAMPING; the metric's central step in
    its frequency left the domain (ValueError) and the exact finish from there failed ("no start of the fit gave a
    valid likelihood"), so the loop kept the composite fit without saying so."""
    edge = OSC(frequency=20.0, bandwidth=2.0 * MAX_DAMPING * 20.0 * (1.0 - 1e-6), sigma=2e-3)
    start = [WN(1e-3), edge]
    y = simulate_sum(start, 20_000, DT, np.random.default_rng(2))
    info = whittle_information(start, y, DT)
    assert np.all(np.isfinite(info)) and np.all(np.diag(info) > 0)
    fit = NoiseModel(y, DT, "WN+OSC").fit(start, FitOptions(uncertainty=False))
    assert np.isfinite(fit.loglik)


def test_the_osc_start_frequencies_are_the_strongest_lines_strongest_first():
    dt, n = 0.01, 120_000
    rng = np.random.default_rng(4)
    t = dt * np.arange(n)
    y = simulate_sum([WN(1e-3), RW(1e-5)], n, dt, rng)
    y += 1e-3 * np.sin(2 * np.pi * 1.3 * t) + 3e-3 * np.sin(2 * np.pi * 0.8 * t) + 1e-4 * np.sin(2 * np.pi * 2.1 * t)
    found = osc_start_frequencies(banded_periodogram(y), dt, 2)
    assert len(found) == 2  # not the weak 2.1 Hz line
    assert found[0] == pytest.approx(0.8, rel=0.03) and found[1] == pytest.approx(1.3, rel=0.03)


def test_the_whittle_gradient_is_the_derivative_of_the_likelihood():
    """Every kind of parameter (scales exactly, shapes by one component's differences) against central differences
    of the banded Whittle log-likelihood itself; whittle_fit climbs on this gradient."""
    y = simulate_sum([WN(2e-3), GM(tau=5.0, sigma=2e-3), RW(2e-5)], 100_000, DT, np.random.default_rng(3))
    start = [WN(2.5e-3), LPF(1e-3, 8.0), BI(5e-5, 1.0, 300.0), GM(tau=3.0, sigma=1.5e-3),
             OSC(frequency=0.5, bandwidth=0.03, sigma=5e-4), RW(3e-5), MA(2e-4)]
    bp = banded_periodogram(y, fine=line_windows([start], DT))
    keys = [(i, k) for i, c in enumerate(start) for k in c.parameter_names]
    x = np.log([start[i].params()[k] for i, k in keys])
    parts = ComponentParts(lambda c: difference_spectrum([c], bp.omega, DT))
    ll, grad = loglik_and_gradient(start, keys, x, bp, parts)
    assert ll == pytest.approx(components_loglik(start, bp, DT), rel=1e-12)
    for j, key in enumerate(keys):
        step = np.zeros(x.size)
        step[j] = 1e-5
        up, down = (components_loglik(with_log_parameters(start, keys, x + s * step), bp, DT) for s in (1, -1))
        assert grad[j] == pytest.approx((up - down) / 2e-5, rel=1e-3, abs=0.05), key


def test_whittle_fit_reaches_the_maximum_its_likelihood_has():
    """The fitted point is a maximum of the banded Whittle likelihood: no log-parameter step of ±0.01 raises it by
    more than L-BFGS-B's relative stopping tolerance (ftol 2.2e-9 of |ℓ|)."""
    truth = [WN(2e-3), OSC(frequency=0.5, bandwidth=0.02, sigma=4e-3), RW(3e-4)]
    y = simulate_sum(truth, 100_000, DT, np.random.default_rng(5))
    bp = banded_periodogram(y, fine=line_windows([truth], DT))
    start = [WN(3e-3), OSC(frequency=0.51, bandwidth=0.05, sigma=2e-3), RW(1e-4)]
    ll, fitted = whittle_fit(start, y, DT, bp)
    assert ll == pytest.approx(components_loglik(fitted, bp, DT), rel=1e-12)
    keys = [(i, k) for i, c in enumerate(fitted) for k in c.parameter_names]
    x = np.log([fitted[i].params()[k] for i, k in keys])
    for j in range(x.size):
        for s in (0.01, -0.01):
            step = np.zeros(x.size)
            step[j] = s
            moved = components_loglik(with_log_parameters(fitted, keys, x + step), bp, DT)
            assert moved <= ll + 5e-9 * abs(ll), keys[j]
    assert fitted[1].params()["frequency"] == pytest.approx(0.5, rel=0.01)


def test_whittle_fit_to_the_maximum_climbs_a_walk_read_from_a_few_frequencies():
    """1 h of WN + RW at 200 Hz: the walk shows in ~20 Fourier frequencies, so ℓ (~3e6) changes by less than one unit
    over ±20 % of K. L-BFGS-B's stopping rule, relative to |ℓ|, left the fit at its start K (the truth), 0.54 below
    the maximum at 1.13 K; climbed ``to_maximum``, no K on a scan of ±50 % around the fit (N held) beats it by more
    than 1e-3."""
    dt = 1.0 / 200.0
    y = simulate_sum([WN(5e-4), RW(2e-5)], 720_000, dt, np.random.default_rng([0, 60, 3]))
    bp = banded_periodogram(y)
    start = [WN(5e-4), RW(2e-5)]
    short_ll, short = whittle_fit(start, y, dt, bp)
    ll, fitted = whittle_fit(start, y, dt, bp, to_maximum=True)
    assert short[1].random_walk == pytest.approx(2e-5, rel=0.01) and ll > short_ll + 0.3
    assert fitted[1].random_walk > 1.05 * 2e-5
    for factor in np.linspace(0.5, 1.5, 41):
        scanned = [fitted[0], RW(fitted[1].random_walk * factor)]
        assert components_loglik(scanned, bp, dt) <= ll + 1e-3, factor


def test_whittle_fit_leaves_a_start_whose_first_step_lands_where_a_resonance_is_undefined():
    """10⁶ samples, a start whose resonance is 2x too strong and 2.5x too wide: the gradient in the white noise (~3e5)
    made L-BFGS-B's first step reach the box's corners, where the resonance is not defined (bandwidth above its
    frequency), and the fit returned its start. Redone in units of the start's information it finds the line within
    1 %."""
    dt, n = 0.01, 1_000_000
    truth = [WN(5e-4), GM(tau=30.0, sigma=1e-4), OSC(frequency=0.5, bandwidth=0.02, sigma=1e-3), RW(2e-5)]
    y = simulate_sum(truth, n, dt, np.random.default_rng(1))
    bp = banded_periodogram(y)
    start = [WN(6e-4), GM(tau=3.0, sigma=3e-4), OSC(frequency=0.5, bandwidth=0.05, sigma=2e-3), RW(3e-5)]
    for to_maximum in (False, True):
        ll, fitted = whittle_fit(start, y, dt, bp, physical_bounds(n, dt), to_maximum=to_maximum)
        assert ll > components_loglik(start, bp, dt) + 1e4
        assert fitted[2].sigma == pytest.approx(1e-3, rel=0.05)
        assert fitted[2].frequency == pytest.approx(0.5, rel=0.01)
