"""The screen on statistics of fixed size (core/estimation/screen.py): refuses what the data do not hold, passes what
they do, whichever statistic sees it (1 h at 100 Hz, 360 000 samples, the starts the closed loop's joint search
makes: a GM at a tenth of the record and flicker noise at the long-τ level, the random walk restarted small)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imu_noise_id.core.estimation.em import screen
from imu_noise_id.core.noise.components import GM, RW, WN, simulate_sum
from imu_noise_id.core.noise.flicker import BI, band_for_record

DT, N = 0.01, 360_000
SPAN = N * DT
CURRENT = [WN(1.7e-4), RW(2e-5)]


def _verdicts(truth: list, seed: int) -> dict[str, screen.Screen]:
    y = simulate_sum(truth, N, DT, np.random.default_rng(seed))
    stats = screen.Statistics.of(y, DT)
    reference = screen.Reference.fit(CURRENT, stats)
    level = CURRENT[1].random_walk ** 2 * SPAN / 30.0  # the walk's AV at a tenth of the record
    small = RW(CURRENT[1].random_walk * 1e-2)
    starts = {"GM": [CURRENT[0], GM(SPAN / 10.0, math.sqrt(level / 0.38)), small],
              "BI": [CURRENT[0], BI(math.sqrt(level / 0.664), *band_for_record(N, DT)), small]}
    return {name: screen.screen(reference, start, stats) for name, start in starts.items()}


@pytest.mark.parametrize("seed", [1, 2])
def test_a_clean_record_refuses_the_joint_search_moves(seed):
    verdicts = _verdicts([WN(1.7e-4), RW(2e-5)], seed)
    for name, verdict in verdicts.items():
        assert not verdict.worth_exact_fit, (name, verdict.describe())
        assert verdict.gain < 3.0 and verdict.extra_parameters == {"GM": 2, "BI": 1}[name]
    assert "ΔBIC" in verdicts["GM"].describe()


def test_flicker_noise_passes_a_gm_started_at_a_tenth_of_the_record():
    """The case a banded-Whittle screen from the move's own start fails: the exact fit takes the GM to τ ≈ 0.8 s
    (log-likelihood gain ≈ 40), while from τ = 360 s the Whittle likelihood gains 2.8 and the block sums 0.8."""
    verdicts = _verdicts([WN(1.7e-4), BI(1e-4, *band_for_record(N, DT)), RW(2e-5)], 1)
    assert verdicts["GM"].worth_exact_fit and verdicts["GM"].gain > 20.0
    assert verdicts["BI"].worth_exact_fit and verdicts["BI"].gain > 20.0


def test_a_short_gm_is_seen_by_the_whittle_likelihood_and_a_long_one_by_the_block_sums():
    """A GM of 2 s gains 269 exactly (bench_screen); one of 120 s (σ 1e-3) gains 6.9 exactly, which the block sums
    read (8.0) where the Whittle likelihood from the move's start reads 4.4: a long-τ GM is what 1 h can barely
    show, and the BIC refuses it either way."""
    short = _verdicts([WN(1.7e-4), GM(2.0, 3e-4), RW(2e-5)], 1)["GM"]
    assert short.worth_exact_fit and short.statistic == "whittle" and short.gain > 200.0
    long = _verdicts([WN(1.7e-4), GM(120.0, 1e-3), RW(2e-5)], 1)["GM"]
    assert long.statistic == "block sums" and 4.0 < long.gain < 12.0 and not long.worth_exact_fit


def test_the_loop_screens_its_joint_search_on_a_long_record_and_keeps_it_exact_on_a_short_one():
    """On 3000 s of clean WN+RW at 100 Hz the joint search's long-τ moves are refused by the screen (no exact refit,
    the figures in the trial's reason); on 1000 s they are refitted exactly, as before the screen."""
    from imu_noise_id.pipelines.loop import run_closed_loop

    y = simulate_sum(CURRENT, 300_000, DT, np.random.default_rng(5))
    result = run_closed_loop(y, DT, "WN+RW")
    joint = [t for s in result.steps for t in s.trials if t.reason.startswith("joint search")]
    screened = [t for t in joint if "screened on statistics of fixed size" in t.reason]
    assert result.final.state.name() == "WN+RW"
    assert {t.finding.effect for t in screened} >= {"GM", "BI"} and all(t.bic is None for t in screened)
    short = run_closed_loop(y[:100_000], DT, "WN+RW")
    joint = [t for s in short.steps for t in s.trials if t.reason.startswith("joint search")]
    assert joint and not any("screened" in t.reason for t in joint) and all(t.bic is not None for t in joint)


def test_model_selection_on_a_long_record_fits_exactly_only_what_can_win():
    from imu_noise_id.core.estimation.em.selection import select_model

    y = simulate_sum([WN(1.7e-4), GM(2.0, 3e-4), RW(2e-5)], N, DT, np.random.default_rng(2))
    sel = select_model(y, DT)
    rows = {r["model"]: r for r in sel.table}
    assert sel.best.model == "WN+GM+RW" and "bic" in rows["WN+RW"]
    screened = [r for r in sel.table if "screened" in r]
    assert screened and all(r["delta_bic_screen"] >= screen.MARGIN and "bic" not in r for r in screened)
    clean = select_model(simulate_sum(CURRENT, N, DT, np.random.default_rng(3)), DT)
    rows = {r["model"]: r for r in clean.table}
    assert clean.best.model == "WN+RW" and "screened" in rows["WN+GM+RW"] and "screened" in rows["WN+2GM"]
