"""Closed-loop outputs: model.yaml ``loop:`` entries, self-contained report.html, the ``loop`` command."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml
from one_story import check_one_story

from imu_noise_id.cli import main
from imu_noise_id.core.axes import ImuSeries
from imu_noise_id.core.noise.components import RW, WN, simulate_sum
from imu_noise_id.pipelines.loop import run_closed_loop
from imu_noise_id.report.html import loop_axis_section
from imu_noise_id.report.model_yaml import write_model_yaml

DT = 0.01


@pytest.fixture(scope="module")
def sine_result():
    n = 8000
    y = simulate_sum([WN(1e-3), RW(2e-5)], n, DT, np.random.default_rng(3))
    y += 4e-3 * np.sin(2 * math.pi * 1.5 * np.arange(n) * DT)
    return run_closed_loop(y, DT, "WN+RW", axis="gyro_z", max_candidates=1)


def test_model_yaml_gets_loop_steps(tmp_path, sine_result):
    path = write_model_yaml(tmp_path / "model.yaml", {}, {"gyro_z": sine_result}, {"command": "loop"})
    doc = yaml.safe_load(path.read_text())
    entry = doc["axes"]["gyro_z"]
    # The loop's final model: the line added, then the random walk (undetectable in 80 s) dropped by re-selection.
    assert (entry["model"], entry["n"], entry["dt"]) == ("WN+SIN", 8000, DT)
    steps = entry["loop"]
    assert steps[0]["added"] is None and steps[0]["evidence"] is None
    assert steps[1]["added"] == "SIN" and steps[1]["how"] == "deterministic regressor"
    assert steps[1]["dropped"] == ["RW"] and steps[0]["dropped"] == []
    assert steps[1]["regressors"]["SIN1"]["frequency"] == pytest.approx(1.5, abs=1 / (8000 * DT))
    for key in ("loglik", "bic", "av_misfit", "ljung_box_p", "peak_ratio"):
        assert key in steps[0]["error"]
    assert steps[1]["error"]["bic"] < steps[0]["error"]["bic"]
    verdict = entry["loop_verdict"]
    assert verdict["final_model"] == "WN+SIN" and verdict["passed"] and verdict["av_inside_band"]


def test_report_html_is_self_contained(tmp_path, sine_result):
    text = loop_axis_section("gyro_z", sine_result)
    assert text.count("data:image/png;base64,") == 3  # Allan before/after + ACF/PSD of both steps
    assert "src=\"http" not in text and "WN+SIN" in text and "deterministic regressor" in text
    assert "dropped RW" in text


def test_a_step_between_two_others_has_its_residual_figure_drawn_once(monkeypatch, sine_result):
    """Steps 0 → 1 → 2: step 1's residuals show in both pairs, one drawing (the figure costs a spectrum and a PNG)."""
    import dataclasses

    from imu_noise_id.report import html as report_html

    first, second = sine_result.steps
    three = dataclasses.replace(sine_result, steps=[first, second, dataclasses.replace(second, index=2)])
    drawn = []
    draw = report_html.residual_acf_psd
    monkeypatch.setattr(report_html, "residual_acf_psd",
                        lambda step, title: drawn.append(step.index) or draw(step, title))
    text = loop_axis_section("gyro_z", three)
    assert sorted(drawn) == [0, 1, 2]
    assert text.count("data:image/png;base64,") == 2 + 4  # two Allan figures, each pair's two residual figures
    assert text.count('alt="residual ACF and PSD, step 1"') == 2


def test_loop_command_on_a_bag(tmp_path, capsys):
    from imu_noise_id.bag.writer import write_bag

    n = 6000
    rng = np.random.default_rng(4)
    gyro = np.column_stack([simulate_sum([WN(1e-3)], n, DT, rng) for _ in range(3)])
    accel = np.column_stack([simulate_sum([WN(2e-3)], n, DT, rng) for _ in range(3)]) + np.array([0.0, 0.0, 9.81])
    write_bag(tmp_path / "bag", ImuSeries(t=np.arange(n) * DT, gyro=gyro, accel=accel))
    out = tmp_path / "out"
    assert main(["loop", str(tmp_path / "bag"), "--axes", "gyro_x", "--start", "WN", "--out", str(out)]) == 0
    assert "residuals pass" in capsys.readouterr().out
    assert (out / "report.html").exists()
    assert yaml.safe_load((out / "model.yaml").read_text())["axes"]["gyro_x"]["loop"][0]["model"] == "WN"
    assert main(["loop", str(tmp_path / "bag"), "--axes", "gyro_q", "--out", str(out)]) == 2


def test_analyze_runs_the_loop_after_the_model_fit(tmp_path, capsys):
    from imu_noise_id.bag.writer import write_bag

    n = 4000
    rng = np.random.default_rng(5)
    gyro = np.column_stack([simulate_sum([WN(1e-3)], n, DT, rng) for _ in range(3)])
    gyro[:, 2] += 5e-3 * np.sin(2 * math.pi * 2.0 * np.arange(n) * DT)  # undeclared line on gyro_z
    accel = np.column_stack([simulate_sum([WN(2e-3)], n, DT, rng) for _ in range(3)])
    accel[:, 2] += 9.81
    write_bag(tmp_path / "bag", ImuSeries(t=np.arange(n) * DT, gyro=gyro, accel=accel))
    out = tmp_path / "out"
    assert main(["analyze", str(tmp_path / "bag"), "--model", "WN", "--out", str(out)]) == 0
    check_one_story(capsys.readouterr().out, out)  # the loop's final model (gyro_z: WN+SIN) in every output
    axes = yaml.safe_load((out / "model.yaml").read_text())["axes"]
    assert [s["added"] for s in axes["gyro_z"]["loop"]] == [None, "SIN"]
    assert axes["gyro_x"]["loop_verdict"]["passed"]
    assert (out / "report.html").exists()
    out2 = tmp_path / "out2"
    assert main(["analyze", str(tmp_path / "bag"), "--model", "WN", "--no-loop", "--out", str(out2)]) == 0
    assert "loop" not in yaml.safe_load((out2 / "model.yaml").read_text())["axes"]["gyro_z"]
