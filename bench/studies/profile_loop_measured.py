"""Where the closed loop spends its time on one measured ADIS16405 axis: cProfile, stopped after a time limit.

The full 10⁶-sample records take an hour or more per heavy axis, so the profile is taken for at most
``--limit`` seconds and printed either way (stopped or finished), sorted by cumulative time::

    PYTHONPATH=$PWD OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/studies/profile_loop_measured.py \\
        --run 3 --axis gyro_x --samples 0 --limit 1500 --stats /tmp/r3gx.prof

Needs ``../shared/data/adis16405_static`` (third-party data, not in the repository).
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import signal
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # bench/, for its shared helpers

from common import adis_data_missing, load_adis_run  # bench/common.py

from imu_noise_id.core.axes import AXES
from imu_noise_id.pipelines.loop import run_closed_loop


class _TimeUp(BaseException):
    """Raised by the alarm to stop the loop at the time limit (not an Exception: no handler in the loop catches it)."""


def _stop(*_) -> None:
    raise _TimeUp


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", type=int, default=3)
    parser.add_argument("--axis", default="gyro_x", choices=AXES)
    parser.add_argument("--samples", type=int, default=0, help="first N samples (0 = all)")
    parser.add_argument("--limit", type=int, default=1500, help="stop after this many seconds [s]")
    parser.add_argument("--stats", default="loop.prof", help="where the raw cProfile statistics go")
    parser.add_argument("--top", type=int, default=45, help="functions printed")
    args = parser.parse_args(argv)
    if adis_data_missing():
        return 2
    data, dt = load_adis_run(args.run, args.samples)
    y = data[:, AXES.index(args.axis)]
    signal.signal(signal.SIGALRM, _stop)
    profiler = cProfile.Profile()
    start = time.perf_counter()
    status = "finished"
    signal.alarm(args.limit)
    profiler.enable()
    try:
        result = run_closed_loop(y, dt, "WN+RW", axis=args.axis)
    except _TimeUp:
        status, result = "stopped", None
    finally:
        profiler.disable()
        signal.alarm(0)
    print(f"run {args.run} {args.axis}, {y.size} samples: {status} after {time.perf_counter() - start:.1f} s"
          + (f" with {result.steps[-1].diagnosis.fit.model}" if result is not None else ""), flush=True)
    profiler.dump_stats(args.stats)
    pstats.Stats(args.stats).sort_stats("cumulative").print_stats(args.top)
    return 0


if __name__ == "__main__":
    sys.exit(main())
