"""Throughput of ``imu-noise-id batch`` with 1 and 2 Dask workers on this machine, side by side in one run.

Usage::

    PYTHONPATH=$PWD python bench/bench_batch.py [--bags 8] [--minutes 10] [--out docs/results/bench_batch.txt]

Simulates ``--bags`` static bags (``--minutes`` at 100 Hz each, gyro WN+GM+RW, accel WN+RW), then runs the default
analysis (model selection + closed loop) on all of them with a local cluster of 1 worker and then of 2 workers
(fresh output folders, so nothing is skipped), and a third time with 2 workers on the finished folder (every unit
skipped: the cost of a resumed batch). Printed: wall time, bags per minute, the speed-up, and the peak memory of a
worker (polled every 0.2 s from the scheduler's worker metrics).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import tempfile
import threading
import time
from pathlib import Path

from imu_noise_id.batch import discover_units, open_client, run_batch
from imu_noise_id.cli import main as cli
from imu_noise_id.pipelines.analyze import AnalyzeOptions

MODEL = "gyro: WN(1.7e-4)+GM(tau=300, sigma=2e-5)+RW(2e-5); accel: WN(2e-3)+RW(3e-4)"
OPTIONS = AnalyzeOptions()  # analyze's defaults (model selection, the loop, 8 τ per decade)


def timed_batch(units, out: Path, workers: int) -> tuple[float, float, int]:
    """(wall [s], peak worker memory [MiB], units skipped) of one batch on a fresh local cluster."""
    with open_client(None, workers, "4GiB") as client:
        peak, stop = [0.0], threading.Event()

        def poll() -> None:
            while not stop.is_set():
                for w in client.scheduler_info()["workers"].values():
                    peak[0] = max(peak[0], w["metrics"]["memory"] / 2**20)
                time.sleep(0.2)

        thread = threading.Thread(target=poll, daemon=True)
        thread.start()
        start = time.perf_counter()
        result = run_batch(units, OPTIONS, out, client)
        wall = time.perf_counter() - start
        stop.set()
        thread.join()
    assert all(o.status in ("ok", "skipped") for o in result.outcomes), [o.error for o in result.outcomes]
    return wall, peak[0], sum(o.status == "skipped" for o in result.outcomes)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bags", type=int, default=8)
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    lines = [f"# bench/bench_batch.py --bags {args.bags} --minutes {args.minutes:g}: default analysis (model "
             f"selection + loop) of {args.bags} bags of {args.minutes:g} min at 100 Hz; {os.cpu_count()} CPUs, "
             f"load average before {os.getloadavg()[0]:.2f}"]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for i in range(args.bags):
            with contextlib.redirect_stdout(io.StringIO()):
                cli(["simulate", "--model", MODEL, "--rate", "100", "--duration", str(args.minutes * 60),
                     "--out", str(folder / "bags" / f"robot{i:02d}"), "--seed", str(i)])
        units = discover_units([str(folder / "bags" / "*")], None)
        walls = {}
        for workers in (1, 2):
            wall, peak, _ = timed_batch(units, folder / f"out{workers}", workers)
            walls[workers] = wall
            lines.append(f"{workers} worker(s): {wall:7.1f} s, {60 * len(units) / wall:5.2f} bags/min, peak worker "
                         f"memory {peak:.0f} MiB")
        lines.append(f"speed-up with 2 workers: {walls[1] / walls[2]:.2f}x")
        wall, _, skipped = timed_batch(units, folder / "out2", 2)
        lines.append(f"rerun on the finished folder: {wall:.1f} s ({skipped} of {len(units)} units skipped by "
                     "their content hash)")
    lines.append(f"load average after {os.getloadavg()[0]:.2f}")
    print("\n".join(lines))
    if args.out is not None:
        args.out.write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
