"""Bias instability from a fitted model (with its interval) and from the Allan variance, against known truths."""

from __future__ import annotations

import numpy as np
import pytest

from imu_noise_id.core.estimation.em.model import fit_model
from imu_noise_id.core.estimation.em.results import FitResult
from imu_noise_id.core.estimation.readouts.instability import (
    FLICKER_FACTOR,
    bias_instability,
    bias_instability_from_allan,
)
from imu_noise_id.core.noise.components import GM, OSC, RW, WN, simulate_sum, total_allan_variance

DT = 0.01


def _fit_of(components) -> FitResult:
    return FitResult(model="+".join(c.name for c in components), components=list(components), exog_coef={}, se={},
                     ci95={}, loglik=0.0, aic=0.0, bic=0.0, n=1, dt=DT, n_iter=0, converged=True)


def _truth(components, tau_max: float) -> float:
    tau = np.geomspace(DT, tau_max, 4000)
    return float(np.sqrt(total_allan_variance(components, tau, DT)).min()) / FLICKER_FACTOR


def test_model_reading_is_the_minimum_of_the_model_deviation_and_leaves_vibration_out():
    model = [WN(1e-3), GM(tau=10.0, sigma=5e-5), RW(1e-5)]
    got = bias_instability(_fit_of(model), 1000.0)
    assert got.reached and got.value == pytest.approx(_truth(model, 1000.0), rel=1e-3)
    with_vibration = bias_instability(_fit_of([*model, OSC(frequency=0.5, bandwidth=0.05, sigma=5e-3)]), 1000.0)
    assert with_vibration.value == pytest.approx(got.value, rel=1e-12)


def test_a_short_memory_osc_counts_as_the_white_noise_it_is_at_long_tau():
    """A broad 31.5 Hz OSC (the sensor's second-order low-pass, memory 6 ms) is white at the τ of the minimum: the
    reading equals that of a white noise of the passband density √(N_WN² + S_OSC(0)); without it, B is lower."""
    broad = OSC(31.5, 50.0, 0.02)
    model = [WN(3.5e-3), broad, RW(2e-4)]
    got = bias_instability(_fit_of(model), 100.0)
    passband = WN(float(np.sqrt(3.5e-3**2 + broad.psd(1e-9, DT))))
    assert got.value == pytest.approx(_truth([passband, RW(2e-4)], 100.0), rel=0.01)
    assert got.value > 1.1 * _truth([WN(3.5e-3), RW(2e-4)], 100.0)


def test_white_noise_alone_gives_an_upper_bound():
    got = bias_instability(_fit_of([WN(1e-3)]), 100.0)
    assert not got.reached and got.tau_at_minimum == pytest.approx(100.0) and "upper bound" in got.source


def test_an_upper_bound_is_the_upper_end_of_its_interval_as_a_walks_bound_is():
    """A deviation still falling at the longest τ read gives no value, only a bound: B is the 95 % upper end of the
    reading's interval and the interval starts at zero (before: the point reading with its interval above it, so
    the '<' value printed lay below what the interval allowed)."""
    y = simulate_sum([WN(2e-3), RW(2e-4)], 30_000, DT, np.random.default_rng(3))
    fit = fit_model(y, DT, "WN+RW")
    got = bias_instability(fit, 1.0)  # the minimum (about 17 s) lies beyond the τ read
    reading = _truth(list(fit.components), 1.0)
    assert not got.reached and got.ci95[0] == 0.0
    assert got.value == got.ci95[1] > reading
    assert got.method() == "model_upper_bound" and bias_instability(fit, 300.0).method() == "model_minimum"


def test_interval_from_a_real_fit_covers_the_truth():
    truth = [WN(1e-3), RW(1e-5)]  # deviation minimum at τ = √3·N/K ≈ 173 s, inside the 360 s supported
    n = 360_000
    y = simulate_sum(truth, n, DT, np.random.default_rng(4))
    fit = fit_model(y, DT, "WN+RW")
    got = bias_instability(fit, n * DT / 10)
    lo, hi = got.ci95
    assert got.reached and lo < got.value < hi and lo < _truth(truth, n * DT / 10) < hi
    assert hi / lo < 2.0  # 1 h of data pins it down


def test_the_interval_stays_within_what_the_parameters_intervals_allow():
    """10 s of white noise fitted as WN+RW: the walk is not resolved from zero (K's profile interval [0, 2.9e-3])
    and its log-scale variance is huge; log-normal draws of K put B's upper end at 1.9e86. Every draw is held within
    its parameter's own 95 % interval, so B's upper end is at most the reading with N and K at their upper ends."""
    y = simulate_sum([WN(2e-3)], 1000, DT, np.random.default_rng(0))
    fit = fit_model(y, DT, "WN+RW")
    assert fit.ci95["RW.random_walk"][0] == 0.0
    got = bias_instability(fit, 1000 * DT / 10)
    highest = [WN(fit.ci95["WN.noise_density"][1]), RW(fit.ci95["RW.random_walk"][1])]
    lo, hi = got.ci95
    assert not got.reached and lo == 0.0 and got.value == hi  # a bound (the minimum lies beyond 1 s)
    assert _truth(list(fit.components), 1000 * DT / 10) < hi <= _truth(highest, 1000 * DT / 10) * (1 + 1e-3)


def test_allan_reading():
    tau = np.array([0.1, 1.0, 10.0, 100.0])
    avar = np.array([4e-6, 1e-6, 2.5e-7, 1e-6])
    got = bias_instability_from_allan(tau, avar)
    assert got.reached and got.tau_at_minimum == 10.0 and got.value == pytest.approx(5e-4 / FLICKER_FACTOR)
