"""One analysis, one story: the golden run's ``analyze`` (test/golden_run.py) printed on the console, written to
model.yaml, imu.yaml and report.html, names the same final model per axis, the same verdict and the same Allan-band
claim everywhere, and its record-length advice speaks of that model (the checks: test/one_story.py; the demo's
analysis is checked the same way in test_analyze.py)."""

from __future__ import annotations

from one_story import check_one_story


def test_every_output_names_the_same_final_model_and_verdict(golden_run):
    out = golden_run["analyze_imu.yaml"].parent
    check_one_story((out.parent / "analyze_stdout.txt").read_text(), out)
