"""``report.html`` rendered by a real headless Chromium (the system's package): sections present, every figure
decoded and drawn. Skips when Chromium is not installed (``make setup`` installs it where it can)."""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="Chromium is not installed (apt-get install chromium)")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--allow-file-access-from-files"]


def _chromium(*args: str, tmp_path) -> subprocess.CompletedProcess:
    return subprocess.run([CHROMIUM, *FLAGS, f"--user-data-dir={tmp_path / 'profile'}", *args], capture_output=True,
                          text=True, timeout=120, check=True)


def test_report_renders_with_its_sections_and_figures(golden_run, tmp_path):
    report = golden_run["analyze_imu.yaml"].parent / "report.html"
    dom = _chromium("--virtual-time-budget=5000", "--dump-dom", report.as_uri(), tmp_path=tmp_path).stdout
    assert re.search(r"<title>IMU noise analysis: static_bag</title>", dom)
    for section in ("data", "numbers", "overbound", "allan", "selection", "loop"):
        assert f'id="{section}"' in dom, section
    # one Allan panel per axis, plus the closed loop's figures
    assert dom.count("data:image/png;base64,") >= 6
    assert "The numbers to paste" in dom and "accel_x" in dom

    shot = tmp_path / "report.png"
    _chromium("--window-size=1200,2400", f"--screenshot={shot}", report.as_uri(), tmp_path=tmp_path)
    from matplotlib.image import imread

    pixels = imread(shot)[..., :3]
    # Figures drawn, not broken-image icons: the data's blue 95 % band and the model's red dashed line are there.
    band_blue = np.all(np.abs(pixels - np.array([0.82, 0.89, 0.95])) < 0.06, axis=-1).sum()
    model_red = ((pixels[..., 0] > 0.75) & (pixels[..., 1] < 0.3) & (pixels[..., 2] < 0.3)).sum()
    assert band_blue > 5000 and model_red > 200, (band_blue, model_red)
    # the overbound's orange line (matplotlib C1, drawn at alpha 0.85 over white or the band)
    overbound_orange = ((pixels[..., 0] > 0.9) & (np.abs(pixels[..., 1] - 0.55) < 0.1) & (pixels[..., 2] < 0.25)).sum()
    assert overbound_orange > 200, overbound_orange
