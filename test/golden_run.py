"""The golden run: fixed-seed inputs simulated and every command run once on them (shared by several tests).

``test_golden.py`` compares its outputs with ``test/golden/``; other tests (e.g. the analyze end-to-end test) check
their own properties on the same outputs instead of running the commands again.
"""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import yaml

STATIC_MODEL = "gyro: WN(1e-3)+RW(2e-5); accel: WN(2e-3)+GM(tau=20, sigma=2e-3)+RW(4e-5)"


def _robot_bag(path: Path) -> Path:
    from imu_noise_id.bag.writer import write_bag
    from imu_noise_id.core.axes import ImuSeries, OdometrySeries
    from imu_noise_id.core.simulation.robot import simulate_robot

    run = simulate_robot(60.0, np.random.default_rng(11))
    imu = ImuSeries(t=run.imu_t + 100.0, gyro=run.gyro, accel=run.accel)
    odom = OdometrySeries(t=run.odom_t + 100.0, position=run.position, orientation_xyzw=run.orientation_xyzw,
                          linear_velocity=run.linear_velocity, angular_velocity=run.angular_velocity,
                          pose_covariance=run.pose_cov, twist_covariance=run.twist_cov)
    return write_bag(path, imu, odom)


def generate(work: Path) -> dict[str, Path]:
    """Simulate the inputs into ``work`` and run the commands; the result file of each, by golden name."""
    from imu_noise_id.cli import main

    work.mkdir(parents=True, exist_ok=True)
    static = work / "static_bag"
    assert main(["simulate", "--model", STATIC_MODEL, "--rate", "100", "--duration", "600", "--out", str(static),
                 "--seed", "5"]) == 0
    robot = _robot_bag(work / "robot_bag")
    out = {}
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(["analyze", str(static), "--out", str(work / "analyze"), "--overbound"]) == 0
    (work / "analyze_stdout.txt").write_text(printed.getvalue())
    out["analyze_imu.yaml"] = work / "analyze" / "imu.yaml"
    out["analyze_model.yaml"] = work / "analyze" / "model.yaml"
    assert main(["fit", str(static), "--model", "WN+GM+RW", "--axis", "gyro_z", "--axis", "accel_x",
                 "--out", str(work / "fit")]) == 0
    out["fit_model.yaml"] = work / "fit" / "model.yaml"
    assert main(["cmkf", str(robot), "--imu-rotation", "-1.570796327", "0", "1.570796327", "--out",
                 str(work / "cmkf"), "--no-plot"]) == 0
    out["cmkf.yaml"] = work / "cmkf" / "cmkf.yaml"
    assert main(["identify", str(static), "--axis", "gyro_x,accel_z", "--out", str(work / "identify"),
                 "--no-plot"]) == 0
    out["hypotheses.yaml"] = work / "identify" / "hypotheses.yaml"
    assert main(["criteria", "--case", "2", "--trials", "20", "--duration", "200", "--out", str(work / "criteria"),
                 "--no-plot"]) == 0
    out["criteria.json"] = work / "criteria" / "criteria.json"
    return out


def load(path: Path) -> object:
    return json.loads(path.read_text()) if path.suffix == ".json" else yaml.safe_load(path.read_text())
