"""The quasi-Newton finish's evaluation budget (core/estimation/search.py, mle.maximise): within it a fit is as before;
when it stops the finish short of convergence the fit, model.yaml and the final model say so."""

from __future__ import annotations

import numpy as np
import pytest

from imu_noise_id.core.allan import allan_variance
from imu_noise_id.core.estimation.em import mle, search
from imu_noise_id.core.estimation.em.mle import RECENT_EVALUATIONS
from imu_noise_id.core.estimation.em.model import FitOptions, NoiseModel
from imu_noise_id.core.noise.components import GM, RW, WN, simulate_sum
from imu_noise_id.pipelines.analyze.final import final_model
from imu_noise_id.report.model_yaml import fit_to_dict

TRUTH = [WN(1e-3), GM(tau=20.0, sigma=3e-4), RW(1e-5)]
DT, N = 0.1, 36_000
# a start far from the truth, with no EM iteration before the finish: the finish has work to do
FAR = [WN(3e-3), GM(tau=1.0, sigma=3e-3), RW(1e-6)]
NO_INTERVALS = {"em_iter": 0, "uncertainty": False, "spectral_init": False}


@pytest.fixture(scope="module")
def record() -> np.ndarray:
    return simulate_sum(TRUTH, N, DT, np.random.default_rng(2024))


@pytest.fixture(scope="module")
def unbounded(record):
    return NoiseModel(record, DT, "WN+GM+RW").fit(FAR, FitOptions(finish_budget=None, **NO_INTERVALS))


def test_the_default_budget_does_not_bind_on_a_short_record(record, unbounded):
    fit = NoiseModel(record, DT, "WN+GM+RW").fit(FAR, FitOptions(**NO_INTERVALS))
    assert fit.budget_stop is None and unbounded.budget_stop is None
    assert fit.loglik == pytest.approx(unbounded.loglik, abs=1e-6)
    assert unbounded.n_eval > 8  # the case needs more than the budgeted fit below gets


def test_a_finish_stopped_by_its_budget_says_how_far_it_got(record, unbounded, monkeypatch):
    monkeypatch.setattr(search, "MIN_FINISH_EVALUATIONS", 4)
    fit = NoiseModel(record, DT, "WN+GM+RW").fit(FAR, FitOptions(finish_budget=0.0, **NO_INTERVALS))
    # L-BFGS-B checks its evaluation count between iterations: a line search may pass it by a few
    assert 4 <= fit.n_eval <= 4 + 6
    assert fit.budget_stop is not None and fit.budget_stop > 0.0
    assert fit.loglik < unbounded.loglik - 1.0
    text = fit.budget_stop_text()
    assert f"after {fit.n_eval} evaluations" in text and f"last {RECENT_EVALUATIONS}" in text
    entry = fit_to_dict(fit, "gyro_x")
    assert entry["finish_stopped_at_budget"]["evaluations"] == fit.n_eval
    assert entry["finish_stopped_at_budget"]["loglik_rise_last"] == pytest.approx(fit.budget_stop, rel=1e-3)
    assert "finish_stopped_at_budget" not in fit_to_dict(unbounded, "gyro_x")


def test_the_final_model_of_a_stopped_fit_is_flagged_with_its_pasted_numbers(record, monkeypatch):
    monkeypatch.setattr(search, "MIN_FINISH_EVALUATIONS", 4)
    fit = NoiseModel(record, DT, "WN+GM+RW").fit(FAR, FitOptions(finish_budget=0.0, **NO_INTERVALS))
    assert fit.budget_stop is not None
    final = final_model(fit, None, allan_variance(record, DT))
    assert "finish stopped at its budget" in final.source
    for value in (final.noise_density, final.random_walk):
        assert "not at the likelihood's maximum" in value.source


def test_a_refinement_from_the_maximum_stops_once_the_likelihood_stalls(record, unbounded):
    # a gradient test that cannot be met (as a misspecified model's metric may make it): without the stall rule the
    # finish spends its iterations on rounding; with it, it stops RECENT_EVALUATIONS evaluations after ℓ stopped rising
    model = NoiseModel(record, DT, "WN+GM+RW")
    base = model.statespace(unbounded.components)
    par = mle.Parameterisation.of(unbounded.components)
    kwargs = {"y": record, "z": model.z, "grad_tol": 1e-12, "max_iter": 60}
    plain = mle.maximise(par, base, **kwargs)
    refined = mle.maximise(par, base, stop_stalled=True, **kwargs)
    assert refined.message.startswith("stalled") and not refined.converged and refined.budget_stop is None
    assert refined.n_eval < plain.n_eval
    assert refined.n_eval <= 2 * (RECENT_EVALUATIONS + 1)
    assert plain.loglik - refined.loglik < mle.STALLED_RISE
    assert refined.loglik >= unbounded.loglik - 1e-6


def test_a_refit_with_the_stall_rule_is_the_fit_without_it_where_the_gradient_test_ends_it(record, unbounded):
    fit = NoiseModel(record, DT, "WN+GM+RW").fit(FAR, FitOptions(finish_budget=None, stop_stalled=True,
                                                                 **NO_INTERVALS))
    assert fit.loglik == pytest.approx(unbounded.loglik, abs=1e-6)
