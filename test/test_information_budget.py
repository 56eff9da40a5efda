"""The observed information's budget (core/estimation/uncertainty.py): past it a fit's standard errors come from
Whittle's expected information (core/estimation/whittle.fisher_information), which agrees with the observed one where
the model holds, and every Wald interval's method says which information it used."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from imu_noise_id.core.estimation.em import mle, uncertainty, whittle
from imu_noise_id.core.estimation.em.model import FitOptions, NoiseModel
from imu_noise_id.core.kalman import statespace as ss
from imu_noise_id.core.noise.components import GM, OSC, RW, WN, simulate_sum

TRUTH = [WN(2e-3), GM(tau=2.0, sigma=1e-3), OSC(frequency=7.0, bandwidth=0.2, sigma=1e-3), RW(1e-4)]
DT, N = 0.01, 100_000


@pytest.fixture(scope="module")
def record() -> np.ndarray:
    return simulate_sum(TRUTH, N, DT, np.random.default_rng(77))


@pytest.fixture(scope="module")
def fit(record):
    return NoiseModel(record, DT, "WN+GM+OSC+RW").fit(list(TRUTH), FitOptions(uncertainty=False))


def test_whittle_information_agrees_with_the_observed_one_where_the_model_holds(fit):
    (y, z), model = fit.record, fit.statespace
    comps = ss.to_components(model)
    par = mle.Parameterisation.of(comps)
    theta = par.to_theta(comps)
    observed = mle.observed_information(par, theta, model, y, z)
    expected = whittle.fisher_information(comps, fit.n, DT)
    se_observed = np.sqrt(np.diag(np.linalg.inv(observed)))
    se_expected = np.sqrt(np.diag(np.linalg.inv(expected)))
    # sampling error of the observed information at 1e5 samples, and the Whittle likelihood's end effects
    assert se_expected == pytest.approx(se_observed, rel=0.2)


def test_past_the_budget_the_wald_intervals_name_the_whittle_information(fit, monkeypatch):
    within = uncertainty.add_uncertainty(replace(fit, se={}, ci95={}, ci95_method={}))
    assert "wald" in within.ci95_method.values()
    assert uncertainty.WHITTLE_WALD not in within.ci95_method.values()
    monkeypatch.setattr(uncertainty, "INFORMATION_BUDGET", 0.0)
    past = uncertainty.add_uncertainty(replace(fit, se={}, ci95={}, ci95_method={}))
    for lab, how in within.ci95_method.items():
        if how == "wald":
            assert past.ci95_method[lab] == uncertainty.WHITTLE_WALD
            assert past.se[lab] == pytest.approx(within.se[lab], rel=0.2)
    assert any(how == uncertainty.WHITTLE_WALD for how in past.ci95_method.values())
