"""The final fit's intervals belong to the likelihood's maximum, or say loudly that they do not.

A search started where a white noise has collapsed beside a random walk (N ≈ 0, where the likelihood is flat in
log N) stops there and reports convergence, 10⁴ below the maximum in log-likelihood; the profile search of its
intervals meets the maximum and records it (``FitResult.better_loglik``). Intervals computed around such a point
excluded the point itself (N = 6e-8 with the interval 3e-4 … 9e-4).
"""

from __future__ import annotations

import numpy as np
import pytest

from imu_noise_id.core.allan import allan_variance
from imu_noise_id.core.estimation.em.model import FitOptions, NoiseModel
from imu_noise_id.core.noise.components import RW, WN, simulate_sum
from imu_noise_id.pipelines.analyze.final import final_model
from imu_noise_id.pipelines.loop.run import final_intervals
from imu_noise_id.pipelines.loop.state import LoopResult, LoopState, LoopStep
from imu_noise_id.pipelines.loop.steps import AxisLoop
from imu_noise_id.report.model_yaml import fit_to_dict

DT = 0.01
N_TRUE = 1e-3


@pytest.fixture(scope="module")
def collapsed():
    """A WN+RW record, its loop and a step whose fit stopped at the collapsed white noise."""
    y = simulate_sum([WN(N_TRUE), RW(2e-5)], 20_000, DT, np.random.default_rng(0))
    loop = AxisLoop(y, DT, None, alpha=0.01, lags=20, outliers="impute")
    state = LoopState(structure=["WN", "RW"])
    stuck = NoiseModel(y, DT, "WN+RW").fit([WN(1e-9), RW(2e-5)], FitOptions(uncertainty=False))
    step = LoopStep(1, state.name(), "RW", None, None, state, loop.diagnose(state, stuck), [])
    return y, loop, step


@pytest.fixture(scope="module")
def refitted(collapsed):
    """:func:`final_intervals` of the collapsed step: (step, note)."""
    _, loop, step = collapsed
    return final_intervals(loop, step)


def test_premise_a_search_from_a_collapsed_white_noise_stops_short_of_the_maximum(collapsed):
    _, loop, step = collapsed
    best = loop.diagnose(LoopState(structure=["WN", "RW"]))
    assert step.diagnosis.fit.converged and step.diagnosis.fit.loglik < best.fit.loglik - 1000
    assert step.diagnosis.fit.components[0].noise_density < 1e-6


def test_the_final_step_is_fitted_again_where_its_intervals_met_the_maximum(collapsed, refitted):
    step = collapsed[2]
    final, note = refitted
    fit = final.diagnosis.fit
    n = fit.components[0].noise_density
    lo, hi = fit.ci95["WN.noise_density"]
    assert lo < n < hi and lo < N_TRUE < hi
    assert fit.loglik > step.diagnosis.fit.loglik + 1000 and final.diagnosis.errors.bic < step.diagnosis.errors.bic
    assert "fitted again" in note and final.state.init is not None


def test_a_final_model_short_of_the_maximum_is_flagged_not_printed_as_if_it_held(collapsed, refitted):
    y, _, step = collapsed
    start = LoopStep(0, "WN+RW", None, None, None, step.state, step.diagnosis, [])
    loop_result = LoopResult(axis="gyro_x", dt=DT, n=y.size, steps=[start, step], passed=True, verdict="",
                             remaining=[])
    final = final_model(step.diagnosis.fit, loop_result, allan_variance(y, DT))
    assert "not at the likelihood's maximum" in final.source
    assert "not at the likelihood's maximum" in final.noise_density.source
    assert fit_to_dict(final.fit)["short_of_maximum"] > 1000  # model.yaml says it of any fit
    assert "short_of_maximum" not in fit_to_dict(refitted[0].diagnosis.fit)
