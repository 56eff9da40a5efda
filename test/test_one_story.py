"""One story per analysis: the console, the files and the node say the same thing about one result.

The Allan-band claim of the closed loop (report.html, model.yaml, console), identify's decision beside its
probabilities (console, hypotheses.yaml), the CMKF replay's summary naming a counter's cause before a generic one,
and numbers people read printed with sensible digits.
"""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from imu_noise_id.core.noise.components import GM, WN, simulate_sum

DT = 0.01


@pytest.fixture(scope="module")
def partly_outside():
    """A white-noise model left on WN + GM data (the loop not allowed a step): its AV follows the data at short τ
    and falls below them where the GM lives."""
    from imu_noise_id.pipelines.loop import run_closed_loop

    y = simulate_sum([WN(1e-3), GM(1.0, 1e-3)], 20000, DT, np.random.default_rng(5))
    return run_closed_loop(y, DT, "WN", axis="gyro_z", max_steps=0)


def test_the_band_claim_says_where_the_model_leaves_the_band(partly_outside):
    from imu_noise_id.pipelines.av_band import av_band_claim

    claim = av_band_claim(partly_outside)
    assert claim.inside == partly_outside.av_inside_band is False
    assert 0 < claim.n_outside < claim.n_tau
    lo = claim.outside[0][0]
    assert lo > 10 * DT  # inside at the shortest τ, where white noise rules
    sentence = claim.sentence()
    assert "at every τ" not in sentence and "outside" in sentence and "inside it elsewhere" in sentence
    assert f"{lo:.3g}" in sentence


def test_report_model_yaml_and_console_give_the_same_band_sentence(tmp_path, partly_outside):
    from imu_noise_id.pipelines.av_band import av_band_claim
    from imu_noise_id.report.console import loop_line, loop_table
    from imu_noise_id.report.html import render_loop_report
    from imu_noise_id.report.model_yaml import write_model_yaml

    sentence = av_band_claim(partly_outside).sentence()
    html_text = render_loop_report({"gyro_z": partly_outside})
    assert sentence in html_text.replace("&#x27;", "'")
    assert "at every τ" not in html_text
    doc = yaml.safe_load(write_model_yaml(tmp_path / "model.yaml", {}, {"gyro_z": partly_outside},
                                          {"command": "loop"}).read_text())
    verdict = doc["axes"]["gyro_z"]["loop_verdict"]
    assert verdict["av_band"] == sentence and verdict["av_inside_band"] is False
    assert verdict["av_outside_band_tau"] and verdict["av_outside_band_tau"][0][0] > 10 * DT
    assert sentence in loop_line("gyro_z", partly_outside)
    assert sentence in loop_table({"gyro_z": partly_outside})
