"""N as ``analyze`` pastes it on measured records, against the data's own passband level: is any axis's N far below
the white noise the data show (a sensor filter's noise taken by another component, N pasted 10⁶ low)?

Usage (from the repository root)::

    PYTHONPATH=$PWD .venv/bin/python bench/bench_measured_passband.py [--adis-runs 1 2 …] [--adis-samples N]

Records: the rest phases of the three BROAD trials (a consumer module at 285.7 Hz, 28–42 s; ``bench/common.py``) and,
with ``--adis-runs``, the first ``--adis-samples`` samples of those ADIS16405 runs (100 Hz; ``bench/common.py``). Each
runs the default ``analyze`` pipeline (model selection, closed loop, final model, the resolution of an untrusted one)
in this process. Printed per axis: the final model, N and its method, the data's passband level (the median Welch PSD
over 1–6 Hz, ``common.data_passband_level``, which shares nothing with the fit) and their ratio; then how many
axes paste an N below half the level (the goal: none). Needs ``../shared/data`` (third-party data, not in the
repository).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from common import BROAD_DATA, adis_data_missing, data_passband_level, load_adis_run, load_broad_rest  # bench/common.py

from imu_noise_id.core.axes import AXES, ImuSeries
from imu_noise_id.pipelines.analyze import AnalyzeOptions, analyze

BROAD_TRIALS = (10, 14, 16)


def _series(data: np.ndarray, dt: float, name: str) -> ImuSeries:
    return ImuSeries(np.arange(data.shape[0]) * dt, data[:, :3], data[:, 3:], topic=name)


def run_record(name: str, data: np.ndarray, dt: float) -> list[tuple[str, float]]:
    """Analyse one record; print a line per axis; (axis, N / passband level) per axis."""
    start = time.process_time()
    result = analyze(_series(data, dt, name), options=AnalyzeOptions(jobs=1, allow_motion=True))
    out = []
    for j, axis in enumerate(AXES):
        final = result.finals[axis]
        level = data_passband_level(data[:, j], dt)
        n = final.noise_density
        ratio = (n.value or float("nan")) / level
        out.append((axis, ratio))
        print(f"{name:22s} {axis:8s} {final.model:26s} N {n.value:10.4g} ({n.method:10s})  passband {level:10.4g}  "
              f"N/level {ratio:6.3f}", flush=True)
    print(f"{name:22s} CPU {time.process_time() - start:.1f} s", flush=True)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--adis-runs", type=int, nargs="*", default=[])
    ap.add_argument("--adis-samples", type=int, default=100_000)
    args = ap.parse_args(argv)
    if not BROAD_DATA.exists() or (args.adis_runs and adis_data_missing()):
        print("../shared/data is not here: nothing to run")
        return 0
    print(f"# bench/bench_measured_passband.py {' '.join(sys.argv[1:])}")
    ratios = []
    for trial in BROAD_TRIALS:
        data, dt = load_broad_rest(trial)
        ratios += run_record(f"BROAD {trial} rest", data, dt)
    for run in args.adis_runs:
        y, dt = load_adis_run(run, args.adis_samples)
        ratios += run_record(f"ADIS16405 run {run}", y, dt)
    r = np.array([x for _, x in ratios])
    print(f"axes: {r.size}; N below half the passband level: {int(np.sum(r < 0.5))}; within 10 % of it: "
          f"{int(np.sum(np.abs(r - 1.0) <= 0.1))}; median N/level {np.median(r):.3f} "
          f"(range {r.min():.3f}–{r.max():.3f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
