"""The loop's refit of a move whose warm start lost likelihood against the model it nests (pipelines/loop/trials.refit):
from the estimator's own starts on a record fitted exactly, not on one searched on the composite likelihood."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from imu_noise_id.core.estimation.em import composite
from imu_noise_id.core.noise.components import GM, RW, WN, simulate_sum
from imu_noise_id.core.noise.modelspec import parse_structure
from imu_noise_id.pipelines.loop import steps, trials
from imu_noise_id.pipelines.loop.state import LoopState

DT = 0.1


@pytest.fixture(scope="module")
def record() -> np.ndarray:
    return simulate_sum([WN(1e-3), GM(tau=5.0, sigma=3e-4), RW(1e-5)], 20_000, DT, np.random.default_rng(7))


def _starts_of_refit(record: np.ndarray, monkeypatch) -> list[bool]:
    """Whether each fit of one refit started from given values, the nested fit made to look unbeatable."""
    loop = steps.AxisLoop(record, DT, None, alpha=0.01, lags=20, outliers="impute")
    nested = loop.diagnose(LoopState(structure=parse_structure("WN+RW")))
    unbeatable = replace(nested, errors=replace(nested.errors, loglik=math.inf))
    fitted = list(nested.fit.components)
    move = LoopState(structure=parse_structure("WN+GM+RW"), init=[fitted[0], GM(tau=5.0, sigma=3e-4), fitted[1]])
    given: list[bool] = []
    diagnose = steps.AxisLoop.diagnose

    def spy(self, state, fit=None, *, exact=False):
        given.append(state.init is not None)
        return diagnose(self, state, fit, exact=exact)

    monkeypatch.setattr(steps.AxisLoop, "diagnose", spy)
    trials.refit(loop, unbeatable, move)
    return given


def test_a_move_that_lost_is_refitted_from_the_estimators_own_starts_on_an_exact_record(record, monkeypatch):
    assert _starts_of_refit(record, monkeypatch) == [True, False]


def test_on_the_composite_likelihood_a_move_that_lost_is_not_refitted_from_the_estimators_own_starts(
        record, monkeypatch):
    monkeypatch.setattr(composite, "MIN_SAMPLES", 10_000)
    assert _starts_of_refit(record, monkeypatch) == [True]


def test_the_candidates_of_a_state_with_removed_samples_share_its_composite_statistics(monkeypatch):
    """Every candidate of a step fits the same record with the state's removed samples imputed: its composite
    statistics (a periodogram and block sums of the whole record) are computed once for them, again only when the
    removed samples change, and equal those of the imputed record computed afresh."""
    rng = np.random.default_rng(5)
    n = composite.MIN_SAMPLES + 10_000
    record = simulate_sum([WN(1e-3), RW(2e-5)], n, DT, rng)
    flagged = np.array([1000, 70_000, 200_000])
    record[flagged] += 0.5
    loop = steps.AxisLoop(record, DT, None, alpha=0.01, lags=20, outliers="impute")
    computed = []
    of = composite.CompositeStatistics.of.__func__
    monkeypatch.setattr(composite.CompositeStatistics, "of",
                        classmethod(lambda cls, y, dt: computed.append(y.copy()) or of(cls, y, dt)))
    imputed = record[flagged - 1]
    for structure in ("WN+RW", "WN+GM+RW"):
        loop.diagnose(LoopState(structure=parse_structure(structure), flagged=flagged, imputed=imputed))
    assert len(computed) == 1
    cleaned = record.copy()
    cleaned[flagged] = imputed
    assert np.array_equal(computed[0], cleaned)
    loop.diagnose(LoopState(structure=parse_structure("WN+RW"), flagged=flagged[:2], imputed=imputed[:2]))
    assert len(computed) == 2
