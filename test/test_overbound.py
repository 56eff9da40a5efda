"""The WN+RW overbound (issue 13): above the bound at every τ, and as small as that allows."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from scipy.optimize import linprog

from imu_noise_id.core.errors import InputError
from imu_noise_id.core.estimation.readouts.overbound import overbound_wn_rw
from imu_noise_id.core.noise.components import GM, RW, WN, total_allan_variance

DT = 0.01
TAU = DT * np.unique(np.round(np.logspace(0, 4, 33)).astype(int))  # 0.01 … 100 s, log grid


def _bound(components, inflate=1.0):
    return inflate * total_allan_variance(components, TAU, DT)


@pytest.mark.parametrize("components", [
    [WN(1.7e-4), GM(30.0, 3e-4), RW(2e-5)],   # a bias-instability bump WN+RW cannot follow
    [WN(2e-3), GM(5.0, 1e-3)],                # no random walk at all
    [WN(1e-3), RW(1e-3)],                     # random walk dominant from 3 s on
])
def test_above_the_bound_everywhere_and_as_small_as_that_allows(components):
    bound = _bound(components)
    ob = overbound_wn_rw(TAU, bound, DT)
    av = ob.allan_variance(TAU, DT)
    assert np.all(av >= bound * (1 - 1e-12))  # above the bound at every τ of the range
    # optimal: scipy's LP (HiGHS), an independent solver of the same programme, finds no smaller objective
    G = np.column_stack([WN(1.0).allan_variance(TAU, DT), RW(1.0).allan_variance(TAU, DT)])
    A = G / bound[:, None]  # rows scaled to "≥ 1" and columns to O(1): HiGHS' tolerances are absolute
    scale = 1.0 / A.max(axis=0)
    lp = linprog(c=(A * scale).sum(axis=0), A_ub=-(A * scale), b_ub=-np.ones(len(TAU)),
                 bounds=[(0, None), (0, None)], method="highs")
    assert lp.status == 0
    assert ob.mean_ratio * len(TAU) == pytest.approx(lp.fun, rel=1e-7)
    # minimal: lowering either number that is not already 0 breaks the bound at some τ
    if ob.noise_density > 0:
        lower = WN(ob.noise_density * (1 - 1e-4)).allan_variance(TAU, DT) + RW(ob.random_walk).allan_variance(TAU, DT)
        assert np.any(lower < bound)
    if ob.random_walk > 0:
        lower = WN(ob.noise_density).allan_variance(TAU, DT) + RW(ob.random_walk * (1 - 1e-4)).allan_variance(TAU, DT)
        assert np.any(lower < bound)
    assert ob.binding_tau and all(t in TAU for t in ob.binding_tau)


def test_a_bound_that_is_a_wn_rw_is_returned_exactly():
    bound = _bound([WN(1.7e-4), RW(2e-5)])
    ob = overbound_wn_rw(TAU, bound, DT)
    assert ob.noise_density == pytest.approx(1.7e-4, rel=1e-9)
    assert ob.random_walk == pytest.approx(2e-5, rel=1e-9)
    assert ob.mean_ratio == pytest.approx(1.0, rel=1e-9)


def test_white_noise_alone_when_the_bound_falls_like_it():
    bound = _bound([WN(1e-3)], inflate=1.3)
    ob = overbound_wn_rw(TAU, bound, DT)
    assert ob.random_walk < 1e-9 and ob.noise_density == pytest.approx(1e-3 * np.sqrt(1.3), rel=1e-9)


def test_bad_bounds_are_refused():
    with pytest.raises(InputError, match="at least one"):
        overbound_wn_rw(np.array([]), np.array([]), DT)
    with pytest.raises(InputError, match="positive, finite"):
        overbound_wn_rw(TAU, np.where(TAU > 1, np.nan, 1.0), DT)


def test_floors_keep_the_fitted_values_and_bind_when_the_range_is_short():
    """Over 0.01–1 s a random walk of 2e-5 is invisible: without a floor K would drop to 0; with the fitted values
    as floors K stays at them (reported as at its floor) and the bound still holds."""
    short = TAU[TAU <= 1.0]
    bound = WN(1.7e-4).allan_variance(short, DT)  # what the short range sees: white noise only
    free = overbound_wn_rw(short, bound * 1.2, DT)
    assert free.random_walk < 1e-9  # 0 up to the rounding of collinear constraints
    held = overbound_wn_rw(short, bound * 1.2, DT, floor=(1.7e-4, 2e-5))
    assert held.random_walk == pytest.approx(2e-5, rel=1e-12) and held.at_floor == (False, True)
    assert held.noise_density >= 1.7e-4
    assert np.all(held.allan_variance(short, DT) >= bound * 1.2 * (1 - 1e-12))
    lower = WN(held.noise_density * (1 - 1e-4)).allan_variance(short, DT) + RW(2e-5).allan_variance(short, DT)
    assert np.any(lower < bound * 1.2)  # N is as small as the bound allows once K is held


# --- the overbound stage of analyze, imu.yaml and the exports --------------------------------------------------


@pytest.fixture(scope="module")
def allan_only(tmp_path_factory):
    """An Allan-only analysis (fast) of 10 min at 100 Hz with a GM bump WN+RW cannot follow, written out."""
    from imu_noise_id.core.noise.modelspec import parse_imu_model
    from imu_noise_id.core.simulation.static import simulate_static_imu
    from imu_noise_id.pipelines.analyze import AnalyzeOptions, ModelStage, analyze
    from imu_noise_id.report.analysis import write_analysis

    model = parse_imu_model("gyro: WN(1e-3)+GM(tau=20, sigma=3e-4)+RW(2e-5); accel: WN(2e-3)+RW(4e-5)")
    result = analyze(simulate_static_imu(model, 100.0, 600.0, seed=3), None,
                     AnalyzeOptions(models=ModelStage("none"), horizon_s=50.0))
    out = tmp_path_factory.mktemp("allan_only")
    write_analysis(result, out, meta={}, overbound_exports=True)
    return result, out


def test_analysis_overbound_lies_above_the_data_upper_bound_over_the_range(allan_only):
    result, _ = allan_only
    allan = result.static.allan
    for j, axis in enumerate(result.static.axes):
        ob = result.overbounds[axis]
        assert ob.tau_range[0] == pytest.approx(result.static.dt) and ob.tau_range[1] <= 50.0
        in_range = (allan.tau >= ob.tau_range[0]) & (allan.tau <= ob.tau_range[1])
        assert in_range.sum() > 20
        av = ob.allan_variance(allan.tau[in_range], result.static.dt)
        assert np.all(av >= allan.ci_high[in_range, j] * (1 - 1e-12)), axis
        # not below the Allan-slope values imu.yaml gives without a model stage
        assert ob.inflation_noise_density >= 1 - 1e-12 and ob.inflation_random_walk >= 1 - 1e-12
        assert ob.reference_source == "Allan slopes"
    # the GM bump (σ 3e-4 rad/s over τ ~ 20 s) needs a larger random walk than the slope reading on the gyro
    assert max(result.overbounds[a].inflation_random_walk for a in ("gyro_x", "gyro_y", "gyro_z")) > 1.5


def test_imu_yaml_overbound_section_and_exports(allan_only):
    result, out = allan_only
    doc = yaml.safe_load((out / "imu.yaml").read_text())
    ob = doc["overbound"]
    assert ob["horizon_s"] == 50.0 and ob["tau_range_s"][0] == pytest.approx(0.01)
    assert ob["gyroscope_random_walk"] == pytest.approx(max(ob["gyroscope_random_walk_xyz"]))
    for axis, entry in ob["axes"].items():
        o = result.overbounds[axis]
        assert entry["noise_density"] == pytest.approx(o.noise_density, rel=1e-5)
        assert entry["inflation_random_walk"] == pytest.approx(o.inflation_random_walk, rel=1e-5)
        assert set(entry) >= {"noise_density", "random_walk", "inflation_noise_density", "inflation_random_walk",
                              "tau_range_s", "binding_tau_s"}
    assert "# overbound:" in (out / "imu.yaml").read_text()
    kalibr = yaml.safe_load((out / "exports" / "overbound" / "kalibr_imu.yaml").read_text())
    assert kalibr["gyroscope_random_walk"] == pytest.approx(ob["gyroscope_random_walk"], rel=1e-5)
    plain = yaml.safe_load((out / "exports" / "kalibr_imu.yaml").read_text())
    assert plain["gyroscope_random_walk"] == pytest.approx(doc["gyroscope_random_walk"], rel=1e-5)


def test_a_horizon_shorter_than_the_sampling_period_is_refused_before_the_model_stage(tmp_path, capsys):
    from imu_noise_id.cli import main

    assert main(["simulate", "--model", "gyro: WN(1e-3); accel: WN(2e-3)", "--rate", "100", "--duration", "60",
                 "--out", str(tmp_path / "bag"), "--seed", "1"]) == 0
    capsys.readouterr()
    assert main(["analyze", str(tmp_path / "bag"), "--horizon", "0.001", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "--horizon 0.001 s is shorter than the sampling period" in err and "Traceback" not in err
    assert not (tmp_path / "o" / "model.yaml").exists()
