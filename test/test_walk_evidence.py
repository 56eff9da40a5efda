"""K under model uncertainty (core/estimation/readouts/walk_evidence.py): the structures the data cannot tell apart
each read K; a final K whose interval misses one of their readings is given as their bound."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

from imu_noise_id.core.allan import allan_variance
from imu_noise_id.core.estimation.em import screen
from imu_noise_id.core.estimation.em.model import NoiseModel
from imu_noise_id.core.estimation.em.screen import Maximum, Screen
from imu_noise_id.core.estimation.em.selection import SelectionResult, select_model, suggest_candidates
from imu_noise_id.core.estimation.readouts import kalibr
from imu_noise_id.core.estimation.readouts.kalibr import KalibrValue
from imu_noise_id.core.estimation.readouts.walk_evidence import (
    OCCAM_DELTA,
    WalkReading,
    one_sided_upper,
    over_structures,
    plausible_walks,
    record_walk,
    visible_components,
    walk_interval,
)
from imu_noise_id.core.noise.components import GM, RW, WN, simulate_sum
from imu_noise_id.core.noise.flicker import BI, band_for_record
from imu_noise_id.pipelines.analyze.final import final_model

DT = 1.0 / 200.0
K_TRUE = 2e-5


def test_record_walk_counts_a_gm_slower_than_the_record_as_a_walk() -> None:
    span = 1000.0
    slow, fast = GM(tau=4000.0, sigma=1e-3), GM(tau=20.0, sigma=1e-3)
    assert record_walk([WN(1e-3), RW(3e-5)], span) == pytest.approx(3e-5, rel=1e-12)
    assert record_walk([WN(1e-3), fast], span) == 0.0
    # above its corner the GM's two-sided density (2 sigma^2/tau) / (omega^2 + 1/tau^2) is a walk's K^2/omega^2 with
    # K^2 = 2 sigma^2/tau; a GM slower than the record shows only frequencies above its corner
    assert record_walk([WN(1e-3), slow, RW(3e-5)], span) == pytest.approx(math.hypot(3e-5, math.sqrt(2e-6 / 4000.0)))


def test_readings_inside_the_interval_leave_k_as_it_is() -> None:
    k = KalibrValue(2e-5, (1.5e-5, 2.7e-5), "RW")
    readings = [WalkReading("WN+RW", 0.0, 1.0, 2e-5, (1.5e-5, 2.7e-5)),
                WalkReading("WN+GM+RW", 4.0, 0.0, 1.8e-5, (1.6e-5, 2.6e-5))]
    assert over_structures(k, readings) is k


def test_the_interval_spans_every_reading() -> None:
    k = KalibrValue(3.8e-5, (2.8e-5, 5.3e-5), "RW")
    readings = [WalkReading("WN+RW", 0.0, 2.3, 3.8e-5, (2.8e-5, 5.1e-5)),
                WalkReading("WN+GM+RW", 4.0, 0.0, 2.9e-5, (1.9e-5, 4.2e-5))]
    spanned = over_structures(k, readings)
    assert spanned.method == "model" and spanned.value == 3.8e-5 and spanned.ci95 == (1.9e-5, 5.3e-5)
    assert "WN+GM+RW (BIC +4.0, AIC +0.0 over the best): K 2.9e-05 [1.9e-05, 4.2e-05]" in spanned.source


def test_a_structure_without_a_walk_makes_k_the_upper_end() -> None:
    k = KalibrValue(4.9e-5, (3.5e-5, 6.8e-5), "RW")
    readings = [WalkReading("WN+RW", 0.0, 7.4, 4.9e-5, (3.5e-5, 6.8e-5)),
                WalkReading("WN+GM", 3.8, 0.8, 0.0, (0.0, 0.0)),
                WalkReading("WN+GM+RW", 9.0, 0.0, 2.1e-5, (0.9e-5, 7.5e-5))]
    bound = over_structures(k, readings)
    # the largest one-sided 95 % upper limit, each interval read as Wald on ln K: K exp(z_0.95 ln(hi/K) / z_0.975)
    z = stats.norm.ppf(0.95) / stats.norm.ppf(0.975)
    expected = max(4.9e-5 * (6.8e-5 / 4.9e-5) ** z, 2.1e-5 * (7.5e-5 / 2.1e-5) ** z)
    assert bound.method == "bound" and bound.value == pytest.approx(expected, rel=1e-12)
    assert bound.ci95 == (0.0, bound.value) and bound.value < 6.8e-5  # below every two-sided upper end
    assert "WN+GM (BIC +3.8, AIC +0.8 over the best): no walk over the record" in bound.source
    # an upper bound already (not identified, or no walk in the model) stays what it is
    already = KalibrValue(6.8e-5, (0.0, 6.8e-5), "RW", method="bound")
    assert over_structures(already, readings) is already


def test_a_bound_over_structures_holds_the_truth_as_often_as_its_95_percent_says() -> None:
    """[0, U] is labelled a 95 % interval. The bug: U was the largest two-sided 95 % upper end, so beside a structure
    without a walk [0, U] held a lognormal estimate's truth in 97.5 % of records, a wider bound than claimed."""
    rng = np.random.default_rng(7)
    sd = 0.13  # sd of ln K of one hour of WN + RW (K 2e-5, N 5e-4, 200 Hz)
    estimates = K_TRUE * np.exp(sd * rng.standard_normal(20000))
    no_walk = [WalkReading("WN+GM", 3.0, 1.4, 0.0, (0.0, 0.0))]
    held = [over_structures(KalibrValue(float(e), (float(e) * math.exp(-1.96 * sd), float(e) * math.exp(1.96 * sd)),
                                        "RW"), no_walk).ci95[1] >= K_TRUE for e in estimates]
    assert np.mean(held) == pytest.approx(0.95, abs=0.005)


def test_the_wald_interval_of_a_walk_agrees_with_the_fits_own() -> None:
    """Whittle's expected information of the record's length, without the data, against the fit's interval from the
    exact likelihood (its observed information or profile)."""
    n = int(1200 / DT)
    y = simulate_sum([WN(5e-4), RW(K_TRUE)], n, DT, np.random.default_rng(11))
    fit = NoiseModel(y, DT, "WN+RW").fit()
    profile = kalibr.random_walk(fit).ci95
    wald = walk_interval(list(fit.components), n, DT)
    assert fit.ci95_method["RW.random_walk"] in ("wald", "profile")
    assert wald == pytest.approx(profile, rel=0.1)
    assert walk_interval([WN(5e-4), GM(tau=20.0, sigma=1e-4)], n, DT) == (0.0, 0.0)


def test_a_component_the_fit_collapsed_enters_no_reading() -> None:
    """The bug: a WN+GM+RW fit whose GM collapsed (tau 0.01 s, sigma 2.6e-9 beside a white noise of 1e-3) read K with
    an interval on one machine and "not determined" on another (the GM's information ~1e-22 of the white noise's,
    its null space left to rounding); a walk collapsed to 3e-10 was read as K 3e-10 on one and as no walk on the
    other. Such components hold under a millionth of the spectrum at every frequency of the record and are dropped;
    a GM and a walk the record shows are kept."""
    n, dt = 60_000, 0.01
    collapsed_gm = GM(tau=0.01, sigma=2.6e-9)
    assert visible_components([WN(1e-3), collapsed_gm, RW(2.15e-5)], n, dt) == [WN(1e-3), RW(2.15e-5)]
    assert walk_interval([WN(1e-3), collapsed_gm, RW(2.15e-5)], n, dt) == walk_interval([WN(1e-3), RW(2.15e-5)], n,
                                                                                        dt)
    assert walk_interval([WN(1e-3), GM(tau=20.0, sigma=2e-3), RW(3e-10)], n, dt) == (0.0, 0.0)
    shown = [WN(1e-3), GM(tau=20.0, sigma=1e-4), RW(2e-6)]  # each above a millionth somewhere in 600 s
    assert visible_components(shown, n, dt) == shown


@pytest.fixture(scope="module")
def gm_beside_walk() -> tuple[np.ndarray, object]:
    """20 min at 200 Hz of WN + a GM (tau 20 s) + RW, the GM's AV peak the walk's AV at 100 s: the selection's winner
    WN+RW reads K 2.4x the truth with an interval above it, WN+GM (no walk) is within ΔBIC 6."""
    n = int(1200 / DT)
    gm = GM(tau=20.0, sigma=1.8703719e-4)
    y = simulate_sum([WN(5e-4), gm, RW(K_TRUE)], n, DT, np.random.default_rng([1, 20, 0]))
    return y, select_model(y, DT, ["WN+RW", "WN+GM", "WN+GM+RW"], allan=allan_variance(y, DT))


def test_structures_within_the_evidence_are_read(gm_beside_walk) -> None:
    _, selection = gm_beside_walk
    readings = {r.structure: r for r in plausible_walks(selection, int(1200 / DT), DT)}
    assert selection.best.model == "WN+RW"
    assert "WN+GM" in readings and readings["WN+GM"].random_walk == 0.0
    assert "WN+RW" not in readings  # the winner's K has its own interval
    assert all(min(r.delta_bic, r.delta_aic) <= OCCAM_DELTA for r in readings.values())


def test_the_final_k_beside_an_unseen_gm_is_a_bound_that_holds_the_truth(gm_beside_walk) -> None:
    """The bug: the winner's K (2.4x the truth, its interval above it) was pasted as a model value."""
    y, selection = gm_beside_walk
    allan = allan_variance(y, DT)
    alone = final_model(selection.best, None, allan).random_walk
    assert alone.method == "model" and alone.ci95[0] > K_TRUE  # without the other structures: confidently wrong
    final = final_model(selection.best, None, allan, selection)
    k = final.random_walk
    assert k.method == "bound" and k.ci95[0] == 0.0 and k.value >= one_sided_upper(alone.value, alone.ci95)
    assert k.ci95[0] <= K_TRUE <= k.ci95[1]
    assert "WN+GM" in {r.structure for r in final.walk_readings} and "cannot tell apart" in k.source


def test_a_clear_walk_stays_a_model_value() -> None:
    n = int(1200 / DT)
    y = simulate_sum([WN(5e-4), RW(1e-4)], n, DT, np.random.default_rng(5))
    allan = allan_variance(y, DT)
    selection = select_model(y, DT, ["WN+RW", "WN+GM", "WN+GM+RW"], allan=allan)
    final = final_model(selection.best, None, allan, selection)
    assert final.random_walk.method == "model" and final.walk_readings == ()
    assert final.random_walk.ci95[0] <= 1e-4 <= final.random_walk.ci95[1]


def test_a_candidate_screened_out_is_read_at_the_screens_fit() -> None:
    """A long record's candidate screened out on the statistics of fixed size (never fitted exactly) is read at the
    components the screen fitted; ΔAIC and ΔBIC are taken to the best of all structures, screened ones included."""
    n, dt = 720_000, 1.0 / 200.0
    winner = SimpleNamespace(components=(WN(5e-4), RW(4.8e-5)), bic=0.0, aic=0.0, converged=True)
    no_walk = SimpleNamespace(components=(WN(5e-4), GM(tau=300.0, sigma=3e-4)), bic=9.5, aic=-2.0, converged=True)
    table = [{"model": "WN+RW", "loglik": 0.0, "bic": 0.0, "aic": 0.0, "converged": True},
             {"model": "WN+GM", "loglik": 2.0, "bic": 9.5, "aic": -2.0, "converged": True}]
    gm_walk = (WN(5e-4), GM(tau=20.0, sigma=2e-4), RW(2e-5))
    verdict = Screen((Maximum("block sums", 10.0, gm_walk, ()),), extra_parameters=2, penalty=math.log(n))
    selection = SelectionResult(winner, table, {"WN+RW": winner, "WN+GM": no_walk},
                                screened={"WN+GM+RW": ("WN+RW", verdict)})
    readings = {r.structure: r for r in plausible_walks(selection, n, dt)}
    assert set(readings) == {"WN+GM+RW"}  # WN+GM lies ΔAIC 14 from the screened structure's −16
    screened = readings["WN+GM+RW"]
    assert screened.delta_aic == 0.0 and screened.delta_bic == pytest.approx(2 * math.log(n) - 20.0)
    assert screened.random_walk == pytest.approx(2e-5) and screened.ci95[0] < 2e-5 < screened.ci95[1]


def test_a_screened_candidate_reads_k_relative_to_the_statistics_reading_of_its_reference() -> None:
    """1 h of WN + RW at 200 Hz: the banded periodogram reads the walk at 1.7x the exact fit's K (3.32e-5 against
    1.93e-5), and WN+GM+RW screened from the selection's start gains nothing over WN+RW there; read at the screen's
    own K it widened the pasted K's interval to 2x the truth, a difference between statistics, not structures."""
    n, dt = 720_000, 1.0 / 200.0
    y = simulate_sum([WN(5e-4), RW(K_TRUE)], n, dt, np.random.default_rng([0, 60, 2]))
    exact = (WN(5.0047e-4), RW(1.9277e-5))  # the exact WN+RW fit of this record
    stats = screen.Statistics.of(y, dt)
    reference = screen.Reference.fit(list(exact), stats)
    start = [WN(5.0036e-4), GM(tau=6.886e-3, sigma=5.40e-5), RW(3.318e-5)]  # the selection's start for WN+GM+RW
    verdict = screen.screen(reference, start, stats)
    assert record_walk(list(verdict.components), n * dt) > 1.5 * 1.9277e-5  # the statistic's own reading
    winner = SimpleNamespace(components=exact, bic=0.0, aic=0.0, converged=True)
    table = [{"model": "WN+RW", "loglik": 0.0, "bic": 0.0, "aic": 0.0, "converged": True}]
    selection = SelectionResult(winner, table, {"WN+RW": winner}, screened={"WN+GM+RW": ("WN+RW", verdict)})
    (reading,) = plausible_walks(selection, n, dt)
    assert reading.structure == "WN+GM+RW" and reading.delta_aic <= OCCAM_DELTA
    assert reading.random_walk == pytest.approx(1.9277e-5, rel=0.05)
    assert reading.ci95[0] < K_TRUE < reading.ci95[1] < 1.5 * K_TRUE


def test_an_interval_wider_than_any_order_of_magnitude_is_undetermined() -> None:
    """200 s of a GM of 2 s beside a walk 100x weaker than its short-term drift: sd(ln K) ≈ 360, whose e^(±1.96 sd)
    overflowed; such a walk has no determined interval."""
    components = [WN(9.95e-4), GM(tau=2.09, sigma=2.83e-3), RW(7.15e-6)]
    assert walk_interval(components, 20_000, 0.01) is None
    assert walk_interval([WN(5e-4), RW(2e-5)], 720_000, 0.005) is not None


@pytest.fixture(scope="module")
def slow_gm_hour():
    """1 h at 200 Hz of WN + GM(100 s) + RW whose GM's AV peak equals the walk's AV at 100 s (bench_random_walk's
    WN+GM100+RW cell, seed 4): WN+RW wins the selection; the exact WN+GM+RW (GM 203 s, K 0.72x the truth) gains 1.1,
    within Occam's window on AIC. Its selection, screened (not fitted exactly: 720 000 samples)."""
    n = 720_000
    y = simulate_sum([WN(5e-4), GM(tau=100.0, sigma=1.8703740353387377e-4), RW(K_TRUE)], n, DT,
                     np.random.default_rng([2, 60, 4]))
    return y, select_model(y, DT, ["WN+RW", "WN+GM+RW"])


def test_a_screen_keeps_each_statistics_maximum(slow_gm_hour) -> None:
    """The banded periodogram's best WN+GM+RW puts the GM at a few milliseconds (a gain of 3.1 the exact likelihood
    does not share); the block sums, started from the selection's second AV-fit start (τ ≈ 190 s), find the slow GM
    that takes most of the walk. Both are kept: the verdict reads the larger gain, K reads each."""
    _, selection = slow_gm_hour
    assert selection.best_key == "WN+RW" and "WN+GM+RW" in selection.screened
    verdict = selection.screened["WN+GM+RW"][1]
    maxima = {m.statistic: m for m in verdict.maxima}
    assert set(maxima) == {"whittle", "block sums"} and verdict.maxima[0].statistic == "whittle"
    (fast,) = [c for c in maxima["whittle"].components if isinstance(c, GM)]
    (slow,) = [c for c in maxima["block sums"].components if isinstance(c, GM)]
    assert fast.tau < 1.0 < 50.0 < slow.tau
    assert record_walk(list(maxima["block sums"].components), 3600.0) < 0.5 * K_TRUE


def test_the_final_k_beside_a_slow_gm_spans_the_block_sums_reading(slow_gm_hour) -> None:
    """The miss: WN+RW's K (1.55x the truth, interval [1.28, 1.88]x) was pasted with only the banded periodogram's
    reading of WN+GM+RW beside it (1.54x). The block sums' slow GM reads K at 0.2x with no determined interval (sd of
    ln K ≈ 30 in that structure): it counts at its point, so K's interval holds the truth without reaching 10^27."""
    y, selection = slow_gm_hour
    final = final_model(selection.best, None, allan_variance(y, DT), selection)
    k = final.random_walk
    assert k.method == "model" and 1.3 * K_TRUE < k.value < 1.8 * K_TRUE
    assert k.ci95[0] < K_TRUE < k.ci95[1] < 2.5 * K_TRUE
    (slow,) = [r for r in final.walk_readings if r.structure == "WN+GM+RW at its block sums maximum"]
    assert slow.ci95 is None and slow.random_walk < 0.5 * K_TRUE


def test_a_long_record_offers_flicker_to_the_walks_readings() -> None:
    """1 h at 100 Hz: white noise, a flicker whose AV plateau equals the walk's AV at 100 s, and the walk. The flicker
    shows no plateau in the AV, so nothing in the AV asks for WN+BI+RW; without it the selection took WN+RW, K 2.1x
    the truth in an interval [1.22, 2.57]x. On a record the screen judges (360 000 samples) WN+BI+RW is offered last,
    and K (the final model's, spanned over the structures within the evidence) holds the truth."""
    dt, n = 0.01, 360_000
    plateau = K_TRUE**2 * 100.0 / 3.0
    bi = BI(math.sqrt(plateau * math.pi / (2 * math.log(2))), *band_for_record(n, dt))
    y = simulate_sum([WN(5e-4), bi, RW(K_TRUE)], n, dt, np.random.default_rng([99, 1]))
    allan = allan_variance(y, dt)
    candidates = suggest_candidates(allan)
    assert candidates[-1] == "WN+BI+RW" and "WN+BI+RW" not in suggest_candidates(allan_variance(y[:200_000], dt))
    selection = select_model(y, dt, candidates, allan=allan)
    k = final_model(selection.best, None, allan, selection).random_walk
    assert k.ci95[0] <= K_TRUE <= k.ci95[1] and k.value < 1.8 * K_TRUE
