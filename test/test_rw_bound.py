"""The long-τ random-walk bound (core/allan/rw_bound.py) against known truths: its coverage on simulated random
walks, and a bounded wander whose short-τ AV mimics a random walk."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imu_noise_id.core.allan import allan_variance
from imu_noise_id.core.allan.rw_bound import random_walk_bound
from imu_noise_id.core.noise.components import RW, WN, simulate_sum

DT, N, K = 0.01, 20000, 1e-3


def test_the_bound_holds_the_true_random_walk_at_its_level_where_the_minimum_of_pointwise_limits_does_not():
    """300 records of WN + RW (200 s, τ ≥ 20 s: six AV estimates): the simultaneous 95 % bound is below the true
    K in at most 5 % of them; the minimum of the six pointwise 95 % limits (what the bench printed before) is
    below it in more than 5 %."""
    simultaneous, pointwise = [], []
    for seed in range(300):
        y = simulate_sum([WN(2e-3), RW(K)], N, DT, np.random.default_rng(seed))
        av = allan_variance(y, DT, confidence=0.90, alpha=-2)
        bound = random_walk_bound(av)
        far = av.tau >= 0.1 * N * DT
        simultaneous.append(bound.value)
        pointwise.append(float(np.min(np.sqrt(3.0 * av.ci_high[far, 0] / av.tau[far]))))
    assert bound.estimates == 6 and bound.tau_range[1] == pytest.approx(N * DT / 2, rel=1e-3)
    assert np.mean(np.array(simultaneous) < K) <= 0.05
    assert np.mean(np.array(pointwise) < K) > 0.05
    assert np.median(simultaneous) < 4.0 * K  # a bound, not a vacuous one


def test_the_bound_over_a_pure_random_walk_misses_it_as_often_as_its_level_says_not_a_fraction_of_that():
    """600 records of a random walk alone (200 s, six AV estimates at τ ≥ 20 s, neighbours strongly correlated): the
    least favourable case (any other noise adds AV). A 95 % bound lies below the true K in about 5 % of them; a
    Bonferroni bound over the six estimates, which treats them as independent, did in about 1 % (bound ~1.3x higher
    than its level needs)."""
    misses, walk = 0, RW(K)
    for seed in range(600):
        bound = random_walk_bound(allan_variance(simulate_sum([walk], N, DT, np.random.default_rng(seed)), DT))
        misses += bound.value < K
    assert bound.estimates == 6 and 1.0 < bound.independent < 6.0
    assert 0.03 <= misses / 600 <= 0.07


def test_a_bounded_wander_that_looks_like_a_random_walk_at_short_tau_is_bounded_far_below_it():
    """White noise + a slow sinusoid of period T/2: up to T/20 its AV rises like a random walk, but the record's
    halves have the same mean. The bound is far below the K the rise implies, and flags it."""
    t = np.arange(N) * DT
    y = simulate_sum([WN(2e-3)], N, DT, np.random.default_rng(1)) + 0.05 * np.sin(2 * np.pi * t / (N * DT / 2))
    av = allan_variance(y, DT, confidence=0.90, alpha=-2)
    rise = av.tau <= N * DT / 20
    k_rise = float(np.sqrt(3.0 * av.variance[rise, 0][-1] / av.tau[rise][-1]))
    bound = random_walk_bound(av)
    assert bound.value < 0.3 * k_rise
    assert bound.exceeded_by(k_rise) and not bound.exceeded_by(None) and not bound.exceeded_by(0.1 * bound.value)


def test_a_record_without_long_tau_estimates_has_no_bound():
    y = simulate_sum([WN(2e-3)], 2000, DT, np.random.default_rng(2))
    bound = random_walk_bound(allan_variance(y, DT), tau_min=1e4)
    assert math.isnan(bound.value) and bound.estimates == 0 and not bound.exceeded_by(1.0)


def _bounded_wander_and_random_walk():
    """The bounded wander above and a true random walk, each with its AV and the final model of its WN+RW fit. The
    walk's record is a typical one (the p-value of its true K 0.31): a 95 % bound flags one true walk in twenty (seed
    3's long-τ AV is low enough, p 0.023)."""
    from imu_noise_id.core.estimation.em.model import NoiseModel
    from imu_noise_id.pipelines.analyze.final import final_model

    t = np.arange(N) * DT
    records = {"wander": simulate_sum([WN(2e-3)], N, DT, np.random.default_rng(1))
               + 0.05 * np.sin(2 * np.pi * t / (N * DT / 2)),
               "walk": simulate_sum([WN(2e-3), RW(K)], N, DT, np.random.default_rng(4))}
    allan = {name: allan_variance(y, DT) for name, y in records.items()}
    finals = {name: final_model(NoiseModel(y, DT, "WN+RW").fit(), None, allan[name]) for name, y in records.items()}
    return allan, finals


def test_analyze_flags_a_final_random_walk_the_long_tau_av_does_not_support():
    """The final model of a WN+RW fit to the bounded wander above: its K (fitted to the short-term wander) is
    above the bound, and the Kalibr value's source and model.yaml's entry say so; a true random walk is not
    flagged."""
    from imu_noise_id.report.model_yaml import final_to_dict

    _, flagged = _bounded_wander_and_random_walk()
    assert flagged["wander"].random_walk_above_bound
    assert "above what the data's AV" in flagged["wander"].random_walk.source
    entry = final_to_dict(flagged["wander"])["random_walk_long_tau_bound"]
    assert entry["random_walk_above_it"] and entry["value"] < flagged["wander"].random_walk.value
    assert not flagged["walk"].random_walk_above_bound and flagged["walk"].random_walk.source == "RW"


def test_the_console_and_the_html_report_flag_a_random_walk_above_the_long_tau_bound():
    """The flag reaches where users read K: the console's final table prints the K source's reason below the table
    for the flagged axis only, and report.html's K cell names the bound and is marked as a warning."""
    from types import SimpleNamespace

    from imu_noise_id.core.allan.slopes import fit_axis_slopes
    from imu_noise_id.report.analysis_html import _numbers_section
    from imu_noise_id.report.console import final_table

    allan, finals = _bounded_wander_and_random_walk()
    assert finals["wander"].random_walk_above_bound and not finals["walk"].random_walk_above_bound
    text = final_table(finals)
    assert f"wander   K flagged: {finals['wander'].random_walk.source}" in text and "walk     K flagged" not in text
    slopes = {name: fit_axis_slopes(av) for name, av in allan.items()}
    page = _numbers_section(SimpleNamespace(finals=finals, static=SimpleNamespace(slopes=slopes), numbers=None))
    cells = [row.split("</tr>")[0] for row in page.split("<tr>")[1:]]
    flagged_row = next(c for c in cells if c.startswith("<td class=l>wander"))
    plain_row = next(c for c in cells if c.startswith("<td class=l>walk"))
    assert "<td class=warn>" in flagged_row and "above the long-τ AV" in flagged_row
    assert "class=warn" not in plain_row and "above the long-τ AV" not in plain_row


def test_the_p_value_of_a_random_walk_is_small_exactly_where_the_bound_excludes_it():
    """p < 5 % for any K above the bound and ≥ 5 % below it (the bound is where p crosses the level); p grows
    as K shrinks."""
    t = np.arange(N) * DT
    y = simulate_sum([WN(2e-3)], N, DT, np.random.default_rng(1)) + 0.05 * np.sin(2 * np.pi * t / (N * DT / 2))
    bound = random_walk_bound(allan_variance(y, DT))
    assert bound.p_value(1.01 * bound.value) < 0.05 <= bound.p_value(0.99 * bound.value)
    assert bound.p_value(10 * bound.value) < bound.p_value(2 * bound.value) < 0.05
