"""The composite likelihood of fixed size (core/estimation/composite.py) and the closed loop that searches long records
on it (pipelines/loop/steps.AxisLoop.fit_state, run.exact_finish)."""

from __future__ import annotations

import numpy as np
import pytest

from imu_noise_id.core.estimation.em import composite, mle, whittle
from imu_noise_id.core.estimation.em.model import FitOptions, NoiseModel
from imu_noise_id.core.noise.components import COMPONENT_TYPES, GM, QN, RR, RW, WN, simulate_sum
from imu_noise_id.core.noise.flicker import BI
from imu_noise_id.core.noise.resonant import LPF, OSC
from imu_noise_id.pipelines.loop import run_closed_loop

DT = 0.01
TRUTH = [WN(2e-3), GM(tau=5.0, sigma=2e-3), RW(2e-5)]


@pytest.fixture(scope="module")
def record() -> np.ndarray:
    return simulate_sum(TRUTH, 400_000, DT, np.random.default_rng(7))


def test_its_gradient_is_the_derivative_of_the_likelihood(record):
    # every kind of parameter: scales (exact) and shapes (differences of one component), against central differences
    # of ℓ_c itself
    stats = composite.CompositeStatistics.of(record, DT)
    start = [WN(2.5e-3), LPF(1e-3, 8.0), BI(5e-5, 1.0, 3000.0), GM(tau=3.0, sigma=1.5e-3),
             OSC(frequency=0.5, bandwidth=0.03, sigma=5e-4), RW(3e-5), QN(1e-6)]
    bp = stats.bands(start)
    keys = [(i, k) for i, c in enumerate(start) for k in c.parameter_names]
    x = np.log([start[i].params()[k] for i, k in keys])
    ll, grad = composite.loglik_and_gradient(start, keys, x, stats, bp)
    assert ll == pytest.approx(composite.loglik(start, stats, bp), rel=1e-12)
    for j, key in enumerate(keys):
        h = np.zeros(x.size)
        h[j] = 1e-5
        up, down = (composite.loglik(whittle.with_log_parameters(start, keys, x + s * h), stats, bp) for s in (1, -1))
        assert grad[j] == pytest.approx((up - down) / 2e-5, rel=1e-3, abs=0.05), key


@pytest.mark.parametrize("name", sorted(set(COMPONENT_TYPES) - {"RR"}))
def test_every_component_scales_with_the_square_of_its_scale(name):
    # the composite gradient's exact derivative in a component's scale_name rests on this
    cls = COMPONENT_TYPES[name]
    example = {"WN": WN(1e-3), "QN": QN(1e-4), "RW": RW(1e-5), "GM": GM(tau=2.0, sigma=1e-3),
               "LPF": LPF(1e-3, 5.0), "OSC": OSC(frequency=2.0, bandwidth=0.2, sigma=1e-3), "BI": BI(1e-4)}
    c = example.get(name) or cls(**{k: 1e-3 if k == cls.scale_name else 10.0 for k in cls.parameter_names})
    twice = type(c)(**{**c.params(), **{k: v for k, v in vars(c).items() if k in cls.fixed_names},
                       cls.scale_name: 2.0 * c.params()[cls.scale_name]})
    lags = np.arange(0, 50, dtype=float) * 7
    assert twice.sum_covariance(lags, DT) == pytest.approx(4.0 * c.sum_covariance(lags, DT), rel=1e-12)
    assert twice.psd(np.array([0.1, 1.0, 10.0]), DT) == pytest.approx(4.0 * c.psd(np.array([0.1, 1.0, 10.0]), DT))
    assert RR.scale_name is None


def test_its_maximum_is_near_the_exact_one(record):
    start = [WN(3e-3), GM(tau=2.0, sigma=1e-3), RW(5e-5)]
    stats = composite.CompositeStatistics.of(record, DT)
    ll, fitted = composite.fit(start, stats, mle.physical_bounds(record.size, DT))
    assert ll > composite.loglik(start, stats, stats.bands(start)) + 100.0
    model = NoiseModel(record, DT, "WN+GM+RW")
    exact = model.fit(fitted, FitOptions(uncertainty=False))
    assert exact.components[1].tau == pytest.approx(TRUTH[1].tau, rel=0.25)
    for got, best in zip(fitted, exact.components, strict=True):
        for name, value in best.params().items():
            # the walk is barely seen in 4000 s beside the GM: its estimates agree within their spread
            assert got.params()[name] == pytest.approx(value, rel=1.0 if name == "random_walk" else 0.25), name
    at_composite = model.fit(fitted, FitOptions(em_iter=0, polish=False, uncertainty=False, spectral_init=False))
    # the exact likelihood at the composite maximiser: short of the exact maximum by a few units, not hundreds
    assert 0.0 <= exact.loglik - at_composite.loglik < 20.0


def test_the_loop_on_a_long_record_adds_the_missing_line_and_ends_at_the_exact_maximum():
    truth = [WN(2e-3), OSC(frequency=2.0, bandwidth=0.05, sigma=2e-3), RW(2e-5)]
    y = simulate_sum(truth, composite.MIN_SAMPLES + 10_000, DT, np.random.default_rng(3))
    result = run_closed_loop(y, DT, "WN+RW")
    final = result.final.diagnosis.fit
    assert "OSC" in final.model
    osc = next(c for c in final.components if isinstance(c, OSC))
    assert osc.frequency == pytest.approx(2.0, rel=0.01)
    exact = NoiseModel(y, DT, final.model).fit(list(final.components), FitOptions(uncertainty=False))
    assert final.loglik == pytest.approx(exact.loglik, abs=0.5)
    # the finish's rise is recorded: the composite maximiser of a model holding the truth is a few units short
    assert result.finish_gain is not None and 0.0 <= result.finish_gain < 20.0


def test_model_selection_on_a_long_record_searches_on_it_and_fits_the_winner_exactly(record):
    from imu_noise_id.core.estimation.em.selection import select_model

    sel = select_model(record, DT, candidates=["WN+RW", "WN+GM", "WN+GM+RW"], options=FitOptions(uncertainty=False))
    assert sel.best.model == "WN+GM+RW"
    # the winner is at the exact maximum: an exact fit from the estimator's own starts does no better
    exact = NoiseModel(record, DT, "WN+GM+RW").fit(None, FitOptions(uncertainty=False))
    assert sel.best.loglik == pytest.approx(exact.loglik, abs=0.5)
    rows = {r["model"]: r for r in sel.table}
    assert "likelihood" not in rows["WN+GM+RW"]
    assert all(rows[m].get("likelihood", "").startswith("exact, at the composite") for m in rows
               if m != "WN+GM+RW" and "bic" in rows[m])


def test_a_selection_left_unfinished_is_finished_as_it_would_have_been(record):
    # analyze leaves the winner at the composite maximiser while its closed loop may replace it, and finishes it only
    # when the loop keeps it: the finished selection is the one select_model gives at once
    from imu_noise_id.core.estimation.em.selection import finish_winner, select_model

    options = FitOptions()
    cands = ["WN+RW", "WN+GM", "WN+GM+RW"]
    left = select_model(record, DT, candidates=cands, options=options, finish=False)
    assert left.unfinished and not left.best.ci95
    assert {r["model"]: r for r in left.table}["WN+GM+RW"]["likelihood"].startswith("exact, at the composite")
    done = finish_winner(left, NoiseModel(record, DT, left.best_key), options)
    at_once = select_model(record, DT, candidates=cands, options=options)
    assert not done.unfinished and done.best.ci95
    assert done.best.loglik == pytest.approx(at_once.best.loglik, abs=1e-6)
    assert done.best.ci95.keys() == at_once.best.ci95.keys()
    for name, interval in at_once.best.ci95.items():
        assert done.best.ci95[name] == pytest.approx(interval, rel=1e-6), name
    assert [r.keys() for r in done.table] == [r.keys() for r in at_once.table]
    for got, want in zip(done.table, at_once.table, strict=True):
        for key, value in want.items():
            assert got[key] == (pytest.approx(value, rel=1e-9) if isinstance(value, float) else value), key
