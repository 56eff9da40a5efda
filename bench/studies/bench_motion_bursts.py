"""Motion bursts in measured records: what the static check's burst test (:func:`imu_noise_id.core.stillness.
motion_bursts`) reads on the real recordings of ``../shared/data``.

Usage (from the repository root)::

    PYTHONPATH=$PWD python bench/studies/bench_motion_bursts.py

Per record and axis: the largest spread ratio any burst-long stretch (:data:`~imu_noise_id.core.stillness.
BURST_MIN_S`) holds in all its windows (the statistic :data:`~imu_noise_id.core.stillness.BURST_RATIO` is compared
with), then the static check's bursts and the still stretch it suggests. Records: the six ADIS16405 static runs
(2.8 h each), the MTi-G gyro (1.4 h, one axis) and the BROAD trials' rest phases, as the data's ``movement`` flag
cuts them and 2 s farther from the motion (the flag lags the motion's start by 0.1–1.3 s). What it found is in
docs/bags.md (Static check); it keeps no output.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # bench/, for its shared helpers

import numpy as np
from common import MOTION_MARGIN_S  # bench/common.py
from numpy.lib.stride_tricks import sliding_window_view

from imu_noise_id.core.axes import AXES, ImuSeries
from imu_noise_id.core.stillness import BURST_RATIO, burst_window, spread_ratios, static_check

DATA = Path(__file__).resolve().parents[3] / "shared" / "data"


def sustained(x: np.ndarray, dt: float) -> float:
    """The largest ratio every window of some burst-long stretch of ``x`` reaches."""
    needed = burst_window(dt)[1]
    ratio = spread_ratios(x, dt)
    return float(sliding_window_view(ratio, needed).min(axis=1).max()) if ratio.size >= needed else float("nan")


def report(name: str, gyro: np.ndarray, accel: np.ndarray, dt: float) -> None:
    columns = np.hstack([gyro, accel])
    ratios = "  ".join(f"{axis} {sustained(columns[:, i], dt):6.1f}" for i, axis in enumerate(AXES))
    check = static_check(ImuSeries(t=np.arange(len(gyro)) * dt, gyro=gyro, accel=accel), dt)
    bursts = "; ".join(f"{b.start_s:.1f}–{b.end_s:.1f} s {'+'.join(b.axes)} {b.ratio:.0f}×" for b in check.bursts)
    span = "" if check.still_span is None else f"  still {check.still_span[0]:.1f}–{check.still_span[1]:.1f} s"
    print(f"{name:34s} {len(gyro) * dt:8.1f} s  {ratios}  bursts: {bursts or 'none'}{span}")


def main() -> int:
    if not DATA.is_dir():
        print(f"no data at {DATA}", file=sys.stderr)
        return 2
    print(f"# bench/studies/bench_motion_bursts.py: sustained spread ratio per axis (flagged at {BURST_RATIO:g})")
    for run in range(1, 7):
        d = np.load(DATA / "adis16405_static" / f"adis16405_run{run}.npz")
        report(f"ADIS16405 run {run}", d["gyro"], d["accel"], 1.0 / float(d["fs_hz"]))
    d = np.load(DATA / "mtig_gyro_x_contaminated" / "mtig_cont_gyro_x.npz")
    dt = 1.0 / float(d["fs_hz"])
    print(f"{'MTi-G gyro_x':34s} {d['gyro_x'].size * dt:8.1f} s  gyro_x {sustained(d['gyro_x'], dt):6.1f}")
    for path in sorted((DATA / "broad_trials").glob("broad_*.npz")):
        d = np.load(path)
        moving = d["movement"]
        first, last = int(np.argmax(moving)), len(moving) - int(np.argmax(moving[::-1]))
        dt = float(np.median(np.diff(d["t"])))
        margin = round(MOTION_MARGIN_S / dt)
        trial = path.name.split("_")[1]
        for label, part in (("rest before, as flagged", slice(0, first)),
                            (f"rest before, {MOTION_MARGIN_S:g} s earlier", slice(0, first - margin)),
                            ("rest after, as flagged", slice(last, None)),
                            (f"rest after, {MOTION_MARGIN_S:g} s later", slice(last + margin, None))):
            report(f"BROAD {trial} {label}", d["gyro"][part], d["accel"][part], dt)
    return 0


if __name__ == "__main__":
    sys.exit(main())
