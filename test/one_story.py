"""What one analysis must say the same way everywhere (used by the golden run's and the demo's tests): the final
model per axis, the verdict and the Allan-band claim, in the console, model.yaml, imu.yaml and report.html."""

from __future__ import annotations

import html
import re
from pathlib import Path

import yaml

from imu_noise_id.core.axes import AXES


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


def check_one_story(console: str, folder: Path) -> None:
    """Assert that ``analyze``'s printed ``console`` and its results ``folder`` tell one story (module docstring)."""
    models = yaml.safe_load((folder / "model.yaml").read_text())["axes"]
    imu = yaml.safe_load((folder / "imu.yaml").read_text())
    report = html.unescape((folder / "report.html").read_text())
    imu_final = dict(zip(AXES, imu["gyroscope_final_model_xyz"] + imu["accelerometer_final_model_xyz"], strict=True))
    finals = _rows(console, "Final models")
    advice = _rows(console, "How long to record")
    lines = console.splitlines()
    for axis in AXES:
        entry, verdict = models[axis], models[axis]["loop_verdict"]
        final = entry["final"]["model"]
        assert final == verdict["final_model"] == entry["loop"][-1]["model"] == imu_final[axis] == finals[axis]
        assert advice.get(axis, final) == final
        loop_line = re.search(rf"^{axis}: loop (\S+) .*?-> (\S+): (.*)$", console, re.M)
        assert loop_line.group(2) == final and loop_line.group(3) == verdict["verdict"]
        assert verdict["passed"] == verdict["verdict"].startswith("residuals pass")
        # the band claim: one sentence, printed under the loop line and in the report
        sentence = verdict["av_band"]
        assert lines[lines.index(loop_line.group(0)) + 1].strip() == sentence
        assert sentence in report and verdict["verdict"] in report
        assert ("inside the data's 95 % band" in sentence) == verdict["av_inside_band"]
