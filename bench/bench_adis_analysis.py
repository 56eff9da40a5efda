"""``analyze_static`` on the real ADIS16405 run 1 (2.8 h, 100 Hz): summary, components found, run time.

Beside each axis's Allan-slope white noise: the data's own level, √(½·median of the Welch PSD over 1–6 Hz) (the
reference the measured loop table uses), and the τ below which the slopes were not read (the sensor's low-pass
roll-off, ``slopes`` rule 5).

Run: ``nice -n 10 python bench/bench_adis_analysis.py`` (output in docs/results/bench_adis_analysis.txt).
Needs ``../shared/data/adis16405_static/adis16405_run1.npz`` (third-party data, not in the repository).
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy import signal

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
    f, pxx = signal.welch(np.hstack([d["gyro"], d["accel"]]), fs=result.rate_hz, nperseg=4096, axis=0)
    band = (f >= 1.0) & (f <= 6.0)
    for j, axis in enumerate(result.axes):
        slopes = result.slopes[axis]
        comps = ", ".join(f"{c.name}={c.value:.3g} ({c.method})" for c in slopes.components())
        level = math.sqrt(float(np.median(pxx[band, j])) / 2.0)
        start = slopes.rolloff_tau if slopes.rolloff_tau is not None else result.allan.tau[0]
        print(f"{axis:8s} {comps}; the data's 1-6 Hz level {level:.3g} (WN/level "
              f"{slopes.noise_density.value / level:.3f}); read from tau {start:g} s")
    for w in result.warnings:
        print(f"warning: {w}")


if __name__ == "__main__":
    main()
