"""Time (wall and CPU) and peak memory of the default ``imu-noise-id analyze`` on simulated static bags.

Each bag is analysed by every source tree given, one after the other in the same run, so that a speed claim is a
ratio measured side by side. The default compares this checkout with nothing; ``--baseline DIR`` adds another
checkout of the project (e.g. ``git worktree add ../baseline <commit>``) run with the same Python::

    .venv/bin/python bench/bench_analyze_time.py --baseline ../baseline            # 1 h at 400 Hz (issue 10)
    .venv/bin/python bench/bench_analyze_time.py --rates 200 400                     # issue 11's timings
    .venv/bin/python bench/bench_analyze_time.py --rates 200 --jobs 1 0               # one process vs one per core
    .venv/bin/python bench/bench_analyze_time.py --duration 10800                     # 3 h at 400 Hz (the GMWM)
    .venv/bin/python bench/bench_analyze_time.py --rates 200 --duration 86400 --repeats 2 --baseline ../baseline  # 24 h
    .venv/bin/python bench/bench_analyze_time.py --adis 1 --baseline ../baseline --timeout 1500 --numbers  # measured
    .venv/bin/python bench/bench_analyze_time.py --adis 1 2 3 4 5 6 --allow-motion --timeout 1200   # all six runs
    .venv/bin/python bench/bench_analyze_time.py --adis 1 --adis-seconds 1000 --baseline ../baseline --numbers  # 10⁵
    .venv/bin/python bench/bench_analyze_time.py --adis 1 --baseline ../baseline --repeats 3   # with the spread
    .venv/bin/python bench/bench_analyze_time.py --adis 1 --estimator gmwm --baseline ../baseline --timeout 900

The committed output holds these runs one after another: 1 h at 400 Hz side by side with the checkout before the
screen on statistics of fixed size, 3 h at 400 Hz (this checkout alone), the ADIS16405 run in three turns and 24 h
at 200 Hz in two turns, each side by side with the checkout before the smoother handed over sums, all six ADIS16405
runs (this checkout alone), and 11 min at 100 Hz in three turns, side by side with the checkout before the report's
figures were drawn side by side; each section's second line names its checkouts.

The bag: WN + GM + RW on the gyros and WN + RW on the accelerometers (MEMS-like), rosbag2 mcap, written once by this
checkout; with ``--adis RUN …``, each whole ADIS16405 static run RUN of ``../shared/data`` (10⁶ samples per axis at 100
Hz, ``bench/common.py``; its first ``--adis-seconds`` only when given) instead, and with several runs each checkout's
total wall time over them (run 4 holds motion bursts the static check refuses: ``--allow-motion`` passes that option to
every run; ``--estimator`` passes that option). A checkout still running after ``--timeout`` seconds is stopped and
printed as such (the checkout before the composite search needs hours on a measured record). Printed: per rate, source
and ``--jobs`` value, wall time, CPU time (user + system of the analyze process and of the worker processes it reaped)
and peak memory: the largest RSS of one process and the largest sums of the RSS and of the PSS (shared pages split among
the processes mapping them) of the analyze process and its workers (sampled every :data:`MEMORY_SAMPLE_PERIOD` s), the
PSS also as a multiple of the decoded arrays (stamps and six axes, float64); with ``--numbers``, the N and K each
checkout's ``imu.yaml`` gives per axis. Each checkout runs without the BLAS thread-count variables in its environment,
as from a user's shell. With ``--repeats R`` the checkouts take turns R times on each bag (A B A B …, so that a drift of
the machine's speed falls on both) and each is summarised by its median wall time and range, the ratio by the median of
the turns' ratios and its range: a difference within that range is not one this run can tell from the machine's spread.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import psutil
import yaml
from common import ADIS_DATA, check_imports_own_package, load_adis_run  # bench/common.py, beside this script

from imu_noise_id.bag.writer import write_bag
from imu_noise_id.core.axes import ImuSeries

ROOT = Path(__file__).resolve().parents[1]
#: Left out of the environment the checkouts run in (:func:`_user_environment`).
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
#: The decoded recording per sample: the stamp and six axes, float64 [bytes].
DECODED_BYTES_PER_SAMPLE = 7 * 8
MODEL = "gyro: WN(1.7e-4)+GM(tau=300, sigma=2e-5)+RW(2e-5); accel: WN(2e-3)+RW(3e-4)"


def _tree_memory(pid: int) -> tuple[int, int]:
    """(summed RSS, summed PSS) [bytes] of process ``pid`` and all its descendants ((0, 0) once it is gone). The PSS
    splits each shared page among the processes that map it: a file all workers map counts once, not once each."""
    try:
        root = psutil.Process(pid)
        procs = [root, *root.children(recursive=True)]
    except psutil.Error:
        return 0, 0
    rss = pss = 0
    for proc in procs:
        with contextlib.suppress(psutil.Error):
            info = proc.memory_full_info()
            rss, pss = rss + info.rss, pss + info.pss
    return rss, pss


def _stop_tree(pid: int) -> None:
    """Kill process ``pid`` and its descendants (the analyze process and its workers)."""
    with contextlib.suppress(psutil.Error):
        root = psutil.Process(pid)
        for proc in [*root.children(recursive=True), root]:
            with contextlib.suppress(psutil.Error):
                proc.kill()


def _adis_bag(run: int, path: Path, seconds: float = 0.0) -> int:
    """Write ADIS16405 static run ``run`` (its first ``seconds`` when non-zero) as a rosbag2 mcap bag at ``path``; its
    samples per axis."""
    if not ADIS_DATA.is_dir():
        raise SystemExit(f"no data at {ADIS_DATA}")
    data, dt = load_adis_run(run)
    data = data[: round(seconds / dt)] if seconds else data
    t = dt * np.arange(data.shape[0])
    write_bag(path, ImuSeries(t=t, gyro=data[:, :3], accel=data[:, 3:], frame_id="imu", topic="/imu/data"))
    return data.shape[0]


def _user_environment() -> dict[str, str]:
    """This process's environment without the BLAS thread-count variables (``make`` sets one): each checkout runs
    with what a user's shell gives it, and sets its own threads or not."""
    return {k: v for k, v in os.environ.items() if k not in BLAS_THREAD_VARIABLES}


#: Seconds between samples of the process tree's memory: a sample walks every process's page tables in the kernel
#: (about 6 ms of CPU for analyze's three processes at 10⁶ samples per axis), so sampling every 0.1 s took about 5 %
#: of a core from the run it measured; the memory peaks of analyze's stages last seconds.
MEMORY_SAMPLE_PERIOD = 0.5
#: Seconds between checks whether analyze has ended (its wall time is read this close to its end).
POLL_PERIOD = 0.05


def run_analyze(source: Path, bag: Path, out: Path, jobs: int | None = None, timeout: float = math.inf,
                extra: tuple[str, ...] = ()) -> tuple[float, float, float, float, float] | None:
    """(wall [s], CPU [s], peak RSS of one process, peak summed RSS and PSS of the process tree [MiB]) of
    ``python -m imu_noise_id analyze`` run in ``source`` (with ``--jobs`` when given, and ``extra`` options), after
    checking that it imports the package of ``source``; None when it was stopped after ``timeout`` seconds."""
    check_imports_own_package(source, "analyze")
    env = dict(_user_environment(), PYTHONPATH=str(source))
    cmd = [sys.executable, "-m", "imu_noise_id", "analyze", str(bag), "--out", str(out), *extra]
    start = time.perf_counter()
    proc = subprocess.Popen(cmd + ([] if jobs is None else ["--jobs", str(jobs)]), cwd=source,
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    tree_rss = tree_pss = 0
    sampled = -math.inf
    while True:
        pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            break
        now = time.perf_counter()
        if now - sampled >= MEMORY_SAMPLE_PERIOD:
            rss, pss = _tree_memory(proc.pid)
            tree_rss, tree_pss = max(tree_rss, rss), max(tree_pss, pss)
            sampled = now
        if now - start > timeout:
            _stop_tree(proc.pid)
            proc.wait()
            return None
        time.sleep(POLL_PERIOD)
    wall = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f"analyze from {source} failed:\n{proc.stderr.read()}")
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0, tree_rss / 2.0**20, tree_pss / 2.0**20


def pasted_numbers(out: Path) -> list[str]:
    """Per sensor, the N and K that ``imu.yaml`` of the analyze results folder ``out`` gives per axis: value, 95 %
    interval and method (so that a faster checkout shows whether the numbers users paste moved)."""
    doc = yaml.safe_load(next(out.rglob("imu.yaml")).read_text())
    lines = []
    for sensor in ("gyroscope", "accelerometer"):
        for quantity in ("noise_density", "random_walk"):
            key = f"{sensor}_{quantity}"
            if f"{key}_xyz" not in doc:
                continue
            cells = [f"{v:.4g} [{lo:.3g}, {hi:.3g}] {how}" for v, (lo, hi), how in
                     zip(doc[f"{key}_xyz"], doc[f"{key}_ci_xyz"], doc[f"{key}_method_xyz"], strict=True)]
            lines.append(f"      {key:28s} x, y, z: {'; '.join(cells)}")
    return lines


def _ratio_lines(turns: list[dict[str, float]], names: list[str], timeout: float) -> list[str]:
    """Each other checkout's wall time as a multiple of the first's (``names[0]``), from the turns' wall times [s]
    (inf: stopped at ``timeout``); with several turns, each checkout's median and range first, and the ratio as the
    median of the turns' ratios with their range."""
    first, lines = names[0], []
    if len(turns) > 1:
        for name in names:
            walls = sorted(t[name] for t in turns)
            lines.append(f"  {name:40s} wall median {float(np.median(walls)):7.1f} s over {len(walls)} turns "
                         f"(range {walls[0]:.1f}–{walls[-1]:.1f} s)")
    for name in names[1:]:
        ratios = sorted(min(t[name], timeout) / t[first] for t in turns if math.isfinite(t[first]))
        if not ratios:  # no ratio to a stopped run
            continue
        more = "more than " if any(math.isinf(t[name]) for t in turns) else ""
        spread = f" (turns {ratios[0]:.2f}–{ratios[-1]:.2f}×)" if len(ratios) > 1 else ""
        lines.append(f"  {name}: {more}{float(np.median(ratios)):.2f}× the wall time of {first}{spread}")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rates", type=float, nargs="+", default=[400.0], help="IMU rates [Hz] (default 400)")
    parser.add_argument("--duration", type=float, default=3600.0, help="record length [s] (default 3600)")
    parser.add_argument("--baseline", type=Path, action="append", default=[],
                        help="another checkout to time side by side (repeatable)")
    parser.add_argument("--jobs", type=int, nargs="+", default=None,
                        help="time this checkout with each of these --jobs values (default: its default only)")
    parser.add_argument("--adis", type=int, nargs="+", default=None, metavar="RUN",
                        help="analyze the whole ADIS16405 static runs RUN … (1-6) instead of a simulated bag; with "
                             "several, each checkout's total wall time over them too")
    parser.add_argument("--adis-seconds", type=float, default=0.0, metavar="S",
                        help="with --adis, the first S seconds of each run (default: the whole record)")
    parser.add_argument("--allow-motion", action="store_true",
                        help="pass --allow-motion to analyze (run 4 holds motion bursts the static check refuses)")
    parser.add_argument("--estimator", choices=("auto", "em", "gmwm", "both"), default=None,
                        help="pass --estimator to analyze (default: analyze's own, auto)")
    parser.add_argument("--timeout", type=float, default=math.inf,
                        help="stop a checkout still running after this many seconds")
    parser.add_argument("--repeats", type=int, default=1, metavar="R",
                        help="run the checkouts in turn R times on each bag and print the spread (default 1)")
    parser.add_argument("--numbers", action="store_true",
                        help="print each checkout's N and K as imu.yaml gives them (value, 95 %% interval, method)")
    args = parser.parse_args(argv)
    mine = [("this checkout", None)] if args.jobs is None else [(f"this checkout, --jobs {j}", j) for j in args.jobs]
    sources = [(name, ROOT, jobs) for name, jobs in mine] + [(f"baseline {p}", p.resolve(), None)
                                                              for p in args.baseline]
    print(f"analyze, default options, no BLAS thread-count variable set; {os.cpu_count()} CPUs; load average before: "
          f"{os.getloadavg()[0]:.2f}")
    extra = (("--allow-motion",) if args.allow_motion else ()) + (("--estimator", args.estimator) if args.estimator
                                                                  else ())
    totals: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for rate, run in [(100.0, r) for r in args.adis] if args.adis else [(r, None) for r in args.rates]:
            bag = Path(tmp) / (f"adis_run{run}" if run else f"static_{rate:g}hz")
            if run:
                n = _adis_bag(run, bag, args.adis_seconds)
                what = f"ADIS16405 run {run}, " + (f"first {args.adis_seconds:g} s" if args.adis_seconds else
                                                   "whole record")
            else:
                subprocess.run([sys.executable, "-m", "imu_noise_id", "simulate", "--model", MODEL, "--rate",
                                str(rate), "--duration", str(args.duration), "--out", str(bag), "--seed", "1"],
                               check=True, stdout=subprocess.DEVNULL, env=dict(os.environ, PYTHONPATH=str(ROOT)),
                               cwd=ROOT)
                n = int(args.duration * rate)
                what = f"{args.duration:g} s at {rate:g} Hz"
            arrays = n * DECODED_BYTES_PER_SAMPLE / 2.0**20
            print(f"\n{what} ({n} samples per axis; decoded arrays {arrays:.0f} MiB):")
            turns: list[dict[str, float]] = []
            for turn in range(args.repeats):
                times = {}
                for name, source, jobs in sources:
                    out = Path(tmp) / f"out_{turn}_{len(times)}"
                    label = name if args.repeats == 1 else f"{name}, turn {turn + 1}"
                    measured = run_analyze(source, bag, out, jobs, args.timeout, extra)
                    if measured is None:
                        times[name] = math.inf
                        print(f"  {label:40s} stopped after {args.timeout:.0f} s, not finished", flush=True)
                        continue
                    wall, cpu, rss, tree_rss, tree_pss = measured
                    times[name] = wall
                    totals[name] = totals.get(name, 0.0) + wall / args.repeats
                    print(f"  {label:40s} wall {wall:7.1f} s   CPU {cpu:7.1f} s   peak RSS {rss:7.0f} MiB; process "
                          f"tree: RSS {tree_rss:7.0f} MiB, PSS {tree_pss:7.0f} MiB = {tree_pss / arrays:.1f}× the "
                          "arrays", flush=True)
                    if args.numbers:
                        print("\n".join(pasted_numbers(out)), flush=True)
                turns.append(times)
            print("\n".join(_ratio_lines(turns, [name for name, _, _ in sources], args.timeout)), flush=True)
    if args.adis and len(args.adis) > 1:
        print(f"\nall {len(args.adis)} runs, {6 * len(args.adis)} axes:")
        for name, total in totals.items():
            print(f"  {name:40s} wall {total:7.1f} s = {total / 60:.1f} min in total")
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
