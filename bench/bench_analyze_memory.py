"""Peak memory and time of ``imu-noise-id analyze`` on 1 h at 400 Hz (issue 2: within ~3× the decoded arrays).

Run: ``nice -n 10 python bench/bench_analyze_memory.py`` (output in docs/results/bench_analyze_memory.txt;
needs ~600 MB in the temp dir). Writes a simulated static bag (rosbag2 mcap, 1.44 M messages), then runs the
``analyze`` command in a fresh subprocess and reports its peak resident set size (Linux VmHWM, measured by
:func:`bench_bags.peak_rss_of`) against the size of the decoded float64 arrays (t, gyro, accel) and against the
interpreter's RSS after the same imports.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_bags import make_bag, peak_rss_of  # noqa: E402

#: Partial runs that show where the peak comes from.
VARIANTS = {
    "analyze (default: Allan + EM model selection + closed loop)": [],
    "analyze --model none (Allan stage only)": ["--model", "none"],
}
STAGES = {
    "read_imu": "from imu_noise_id.bag.reader import read_imu; imu = read_imu({bag!r})",
    "read_imu + static_check": "from imu_noise_id.bag.reader import read_imu; "
    "from imu_noise_id.core.stillness import static_check; imu = read_imu({bag!r}); static_check(imu)",
    "read_imu + analyze_static (all 4 kinds)": "from imu_noise_id.bag.reader import read_imu; "
    "from imu_noise_id.pipelines.analyze.static import analyze_static; imu = read_imu({bag!r}); analyze_static(imu)",
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=3600.0, help="recording length [s] (3600)")
    parser.add_argument("--rate", type=float, default=400.0, help="IMU rate [Hz] (400)")
    parser.add_argument("--tmp", type=Path, default=None, help="folder for the bag (default: system temp)")
    args = parser.parse_args()
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))
    with tempfile.TemporaryDirectory(dir=args.tmp, prefix="bench_analyze_") as tmp:
        bag, n = make_bag(Path(tmp), args.rate, args.duration, "mcap")
        arrays = n * 7 * 8
        prelude = ("import imu_noise_id.cli.analyze, imu_noise_id.bag.reader, imu_noise_id.pipelines.analyze.static, "
                   "imu_noise_id.report.analysis, imu_noise_id.report.plots")
        base, _, _ = peak_rss_of([sys.executable, "-c", prelude + "; import time; time.sleep(0.2)"], env)
        runs = {}
        for label, extra in VARIANTS.items():
            cmd = [sys.executable, "-m", "imu_noise_id", "analyze", str(bag), "--out", str(Path(tmp) / "out"), *extra]
            peak, wall, rc = peak_rss_of(cmd, env)
            if rc != 0:
                raise SystemExit(f"{label} failed with exit code {rc}")
            runs[label] = (peak, wall)
        stages = {}
        for label, stage in STAGES.items():
            code = f"{prelude}; {stage.format(bag=str(bag))}; import time; time.sleep(0.2)"
            stages[label], _, rc = peak_rss_of([sys.executable, "-c", code], env)
            if rc != 0:
                raise SystemExit(f"stage {label!r} failed with exit code {rc}")
    mb = 1024**2
    print(f"decoded float64 arrays ({n:,} samples): {arrays / mb:.1f} MiB")
    print(f"interpreter + imports: {base / mb:.1f} MiB")
    for label, (peak, wall) in runs.items():
        print(f"peak RSS of {label}: {peak / mb:.1f} MiB = {peak / arrays:.2f}x the arrays, adds "
              f"{(peak - base) / mb:.1f} MiB = {(peak - base) / arrays:.2f}x over the imports; wall time {wall:.1f} s")
    print("peak RSS of the stages alone (same imports), added over the imports:")
    for label, value in stages.items():
        print(f"  {label:38s} {value / mb:7.1f} MiB  (+{(value - base) / arrays:.2f}x the arrays)")


if __name__ == "__main__":
    main()
