"""One analysis, one story: the golden run's ``analyze`` (test/golden_run.py) printed on the console, written to
model.yaml, imu.yaml and report.html, names the same final model per axis, the same verdict and the same Allan-band
claim everywhere, and its record-length advice speaks of that model."""

from __future__ import annotations

import html
import re

import pytest
import yaml

from imu_noise_id.core.axes import AXES


@pytest.fixture(scope="module")
def outputs(golden_run) -> dict:
    out = golden_run["analyze_imu.yaml"].parent
    return {"console": (out.parent / "analyze_stdout.txt").read_text(),
            "model": yaml.safe_load((out / "model.yaml").read_text())["axes"],
            "imu": yaml.safe_load((out / "imu.yaml").read_text()),
            "report": html.unescape((out / "report.html").read_text())}


def _rows(console: str, heading: str) -> dict[str, str]:
    """The model column of a console table's rows (the lines after ``heading`` that start with an axis)."""
    lines = console.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(heading))
    rows = {}
    for line in lines[start + 1:]:
        words = line.split()
        if not words or words[0] not in AXES:
            break
        rows.setdefault(words[0], words[1])
    return rows


def test_every_output_names_the_same_final_model_and_verdict(outputs):
    models, console, report = outputs["model"], outputs["console"], outputs["report"]
    imu_final = dict(zip(AXES, outputs["imu"]["gyroscope_final_model_xyz"]
                         + outputs["imu"]["accelerometer_final_model_xyz"], strict=True))
    finals = _rows(console, "Final models")
    advice = _rows(console, "How long to record")
    for axis in AXES:
        entry, verdict = models[axis], models[axis]["loop_verdict"]
        final = entry["final"]["model"]
        assert final == verdict["final_model"] == entry["loop"][-1]["model"] == imu_final[axis] == finals[axis]
        assert advice[axis] == final
        loop_line = re.search(rf"^{axis}: loop (\S+) .*?-> (\S+): (.*)$", console, re.M)
        assert loop_line.group(2) == final and loop_line.group(3) == verdict["verdict"]
        assert verdict["passed"] == verdict["verdict"].startswith("residuals pass")
        # the band claim: one sentence, printed under the loop line and in the report
        sentence = verdict["av_band"]
        assert console.splitlines()[console.splitlines().index(loop_line.group(0)) + 1].strip() == sentence
        assert sentence in report and verdict["verdict"] in report
        assert ("inside the data's 95 % band" in sentence) == verdict["av_inside_band"]
