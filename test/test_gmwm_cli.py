"""GMWM through the commands: ``fit --method gmwm``, ``analyze --estimator both|gmwm|auto`` end to end."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from imu_noise_id.cli import main
from imu_noise_id.core.noise.modelspec import parse_imu_model
from imu_noise_id.core.simulation.static import simulate_static_imu

MODEL = "gyro: WN(1e-3)+RW(2e-4); accel: WN(2e-3)+RW(3e-4)"


@pytest.fixture(scope="module")
def bag(tmp_path_factory):
    from imu_noise_id.bag.writer import write_bag

    path = tmp_path_factory.mktemp("gmwm_bag") / "static"
    return write_bag(path, simulate_static_imu(parse_imu_model(MODEL), 100.0, 120.0, seed=21), storage="mcap")


def test_fit_method_gmwm_writes_the_moments(tmp_path, capsys):
    s = simulate_static_imu(parse_imu_model(MODEL), 100.0, 300.0, seed=5)
    path = tmp_path / "imu.npz"
    np.savez(path, t=s.t, gyro=s.gyro, accel=s.accel)
    assert main(["fit", str(path), "--model", "WN+RW", "--method", "gmwm", "--axis", "gyro_x",
                 "--out", str(tmp_path / "out")]) == 0
    ax = yaml.safe_load((tmp_path / "out" / "model.yaml").read_text())["axes"]["gyro_x"]
    assert ax["estimator"] == "gmwm" and ax["loglik"] is None and ax["bic"] is None
    assert all(c["estimator"] == "gmwm" for c in ax["components"])
    wn = ax["components"][0]
    assert wn["ci95"][0] <= 1e-3 <= wn["ci95"][1]
    moments = ax["moments"]
    assert moments["dof"] == len(moments["wavelet_variance"]["tau"]) - 2 and 0 <= moments["p_value"] <= 1
    assert len(moments["wavelet_variance"]["nu2"]) == len(moments["wavelet_variance"]["residual_z"])
    assert "GMWM J" in capsys.readouterr().out
    assert main(["fit", str(path), "--model", "WN+RW", "--method", "gmwm", "--bootstrap", "-1"]) == 2


def test_analyze_both_estimators_side_by_side(bag, tmp_path, capsys):
    out = tmp_path / "both"
    assert main(["analyze", str(bag), "--out", str(out), "--model", "WN+RW", "--estimator", "both",
                 "--no-loop"]) == 0
    printed = capsys.readouterr().out
    assert "EM and GMWM side by side" in printed and "agree" in printed
    axes = yaml.safe_load((out / "model.yaml").read_text())["axes"]
    for axis, entry in axes.items():
        assert entry["estimator"] == "em" and entry["gmwm"]["estimator"] == "gmwm", axis
        rows = entry["agreement"]["parameters"]
        assert {r["quantity"] for r in rows} == {"WN.noise_density", "RW.random_walk"}
        # The same right model on the same data: the two estimators never differ beyond their intervals (a random
        # walk the 2-minute record cannot tell from 0 is "undetermined"), the white noise always agrees.
        assert all(r["verdict"] != "differ" for r in rows), rows
        assert rows[0]["verdict"] == "agree" and abs(rows[0]["ratio"] - 1) < 0.01
        assert "moments" in entry["gmwm"] and "loglik" in entry
    report = (out / "report.html").read_text()
    assert "GMWM (wavelet variance) and the EM side by side" in report and "J-test" not in report[:200]


def test_analyze_uses_the_gmwm_beyond_the_em_threshold(bag, tmp_path, capsys, monkeypatch):
    """--estimator auto (the default) on a record longer than EM_MAX_SAMPLES: the GMWM fits, analyze says so, the
    closed loop (which needs the EM's innovations) is skipped with a message, imu.yaml comes from the GMWM."""
    from imu_noise_id.pipelines.analyze import models

    monkeypatch.setattr(models, "EM_MAX_SAMPLES", 1000)
    out = tmp_path / "auto"
    # in this process: the lowered threshold is this process's alone (spawned workers import the module afresh)
    assert main(["analyze", str(bag), "--out", str(out), "--model", "WN+RW", "--jobs", "1"]) == 0
    err = capsys.readouterr().err
    assert "beyond what the EM fits" in err and "the GMWM was used" in err and "closed loop skipped" in err
    doc = yaml.safe_load((out / "model.yaml").read_text())["axes"]
    # skipped, not attempted: once per axis, and the loop never began on the GMWM's fit
    assert err.count("closed loop skipped") == len(doc) and "the starting fit must be" not in err
    for axis, entry in doc.items():
        assert entry["estimator"] == "gmwm" and "beyond what the EM fits" in entry["note"], axis
        assert "loop" not in entry and "agreement" not in entry
        assert entry["final"]["components"][0]["estimator"] == "gmwm"
    kalibr = yaml.safe_load((out / "imu.yaml").read_text())
    assert all(abs(n / 1e-3 - 1) < 0.05 for n in kalibr["gyroscope_noise_density_xyz"])
