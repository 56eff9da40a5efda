"""``analyze_static`` on the real ADIS16405 run 1 (2.8 h, 100 Hz): summary, components found, run time.

Run: ``nice -n 10 python bench/bench_adis_analysis.py`` (output in docs/results/adis_run1_analysis.txt).
Needs ``../shared/data/adis16405_static/adis16405_run1.npz`` (third-party data, not in the repository).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from imu_noise_id.core.axes import ImuSeries
from imu_noise_id.pipelines.analyze.static import analyze_static
from imu_noise_id.report.console import summary_table

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "adis16405_static" / "adis16405_run1.npz"


def main() -> None:
    if not DATA.is_file():
        sys.exit(f"{DATA} is absent: this benchmark needs ../shared/data (see docs/analysis.md)")
    d = np.load(DATA)
    imu = ImuSeries(t=d["t"], gyro=d["gyro"], accel=d["accel"], topic="adis16405_run1")
    t0 = time.perf_counter()
    result = analyze_static(imu)
    print(f"analyze_static (4 estimators, 6 axes, slope fits): {time.perf_counter() - t0:.1f} s")
    print(summary_table(result))
    for axis in result.axes:
        comps = ", ".join(f"{c.name}={c.value:.3g} ({c.method})" for c in result.slopes[axis].components())
        print(f"{axis:8s} {comps}")
    for w in result.warnings:
        print(f"warning: {w}")


if __name__ == "__main__":
    main()
