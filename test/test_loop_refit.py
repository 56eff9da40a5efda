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
