"""``imu-noise-id fit`` and the model.yaml adapter."""

from __future__ import annotations

import numpy as np
import yaml

from imu_noise_id.cli import main
from imu_noise_id.core.noise.modelspec import parse_imu_model
from imu_noise_id.core.simulation.static import simulate_static_imu


def _npz(tmp_path):
    model = parse_imu_model("gyro: WN(1e-3)+RW(2e-4); accel: WN(2e-3)+GM(tau=2,sigma=3e-3)")
    s = simulate_static_imu(model, 100.0, 30.0, seed=4)
    path = tmp_path / "imu.npz"
    np.savez(path, t=s.t, gyro=s.gyro, accel=s.accel)
    return path


def test_fit_writes_model_yaml(tmp_path, capsys):
    path = _npz(tmp_path)
    rc = main(["fit", str(path), "--model", "WN+RW", "--axis", "gyro_x", "--out", str(tmp_path / "out"),
               "--starts", "1"])
    assert rc == 0
    doc = yaml.safe_load((tmp_path / "out" / "model.yaml").read_text())
    ax = doc["axes"]["gyro_x"]
    assert ax["model"] == "WN+RW" and ax["n"] == 3000 and ax["dt"] == 0.01 and ax["unit"] == "rad/s"
    wn, rw = ax["components"]
    assert wn["type"] == "WN" and wn["ci95"][0] <= 1e-3 <= wn["ci95"][1]
    assert abs(wn["sigma2_wn"] / (wn["noise_density"] ** 2 / 0.01) - 1) < 1e-4  # per-sample = N²/dt
    assert rw["type"] == "RW" and "sigma2_rw" in rw and len(rw["ci95"]) == 2
    assert {"loglik", "aic", "bic", "record_length", "mean"} <= set(ax)
    assert "WN.noise_density" in ax["record_length"]["parameters"]
    assert "gyro_x: WN+RW" in capsys.readouterr().out


def test_fit_errors_exit_2(tmp_path, capsys):
    assert main(["fit", str(tmp_path / "missing.npz"), "--model", "WN+RW"]) == 2
    path = _npz(tmp_path)
    assert main(["fit", str(path), "--model", "WN+RW", "--axis", "gyro_w"]) == 2
    assert main(["fit", str(path), "--model", "RW", "--axis", "gyro_x"]) == 2
    err = capsys.readouterr().err
    assert "no such file" in err and "unknown axis" in err and "WN" in err


def test_allan_band_and_overlay_figure(tmp_path):
    from imu_noise_id.core.estimation.em.model import FitOptions, fit_model
    from imu_noise_id.core.estimation.readouts import kalibr
    from imu_noise_id.core.noise.components import GM, WN, simulate_sum
    from imu_noise_id.core.simulation.bands import allan_band
    from imu_noise_id.report.plots_model import save_allan_overlay

    y = simulate_sum([WN(0.01), GM(tau=1.0, sigma=0.02)], 4000, 0.01, np.random.default_rng(2))
    fit = fit_model(y, 0.01, "WN+GM", options=FitOptions(n_starts=1))
    tau, band = allan_band(fit.components, fit.dt, 4000, n_sim=20, seed=1)
    theory = fit.theoretical_allan_variance(tau)
    # The simulations scatter around the fitted model's theoretical AV (median within 15 % at short τ).
    assert band.shape == (20, tau.size)
    assert np.all(np.abs(np.median(band[:, :5], axis=0) / theory[:5] - 1) < 0.15)
    assert kalibr.noise_density(fit).value == fit.components[0].params()["noise_density"]
    assert kalibr.random_walk(fit).value is None  # WN+GM: no random walk to give Kalibr
    from imu_noise_id.core.allan import allan_variance

    av = allan_variance(y, 0.01)
    out = save_allan_overlay(tmp_path / "f.png", [{"tau": av.tau, "avar": av.variance[:, 0], "fit": fit,
                                                   "simulations": (tau, band)}])
    assert out.exists() and out.stat().st_size < 300_000


def test_analyze_em_stage_through_a_bag(tmp_path, capsys):
    from imu_noise_id.bag.writer import write_bag

    model = parse_imu_model("gyro: WN(1e-3)+RW(2e-4); accel: WN(2e-3)+RW(3e-4)")
    bag = write_bag(tmp_path / "static", simulate_static_imu(model, 100.0, 60.0, seed=8), storage="mcap")
    out = tmp_path / "res"
    assert main(["analyze", str(bag), "--out", str(out), "--model", "WN+RW"]) == 0
    assert (out / "model.yaml").is_file() and (out / "allan_model.png").is_file()
    axes = yaml.safe_load((out / "model.yaml").read_text())["axes"]
    assert set(axes) == {"gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"}
    kalibr = yaml.safe_load((out / "imu.yaml").read_text())
    final_n = kalibr["gyroscope_noise_density_xyz"]
    assert kalibr["gyroscope_noise_density"] == max(final_n) and "gyroscope_noise_density_allan" in kalibr
    assert all(abs(n / 1e-3 - 1) < 0.05 for n in final_n)  # 6000 samples: se of N ≈ 1 %
    # The intervals written are those of the numbers written.
    assert all(lo < n < hi for n, (lo, hi) in zip(final_n, kalibr["gyroscope_noise_density_ci_xyz"], strict=True))
    assert "gyro_z: WN+RW" in capsys.readouterr().out
