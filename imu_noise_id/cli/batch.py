"""``imu-noise-id batch BAG_OR_GLOB…``: ``analyze`` over many bags and IMU topics on Dask (:mod:`imu_noise_id.batch`),
with a fleet table and report (:mod:`imu_noise_id.report.fleet`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from . import add_rate_option
from .options import add_analysis_options, add_out, add_topic, analysis_options


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``batch`` parser."""
    p = subparsers.add_parser(
        "batch", help="analyze many bags / IMU topics on a Dask cluster, with a fleet table and report",
        description=(
            "Run the analyze pipeline on every (bag, IMU topic) unit of the inputs on Dask: a local cluster of "
            "worker processes on 127.0.0.1 by default, or an existing one with --scheduler. Each unit's outputs "
            "land in DIR/<unit>/ as analyze writes them; DIR/fleet.csv and DIR/fleet.parquet hold one row per unit "
            "and axis (N, K, bias instability with 95 % intervals, model, loop verdict, warnings, error); "
            "DIR/fleet_report.html shows their spread, robust outliers and the pass/fail against --spec. A failed "
            "unit is recorded and the batch goes on (exit code 1 once it is done); rerunning the same command skips "
            "units whose bag contents and "
            "options are unchanged. Every unit runs with analyze's options (the same flags and defaults; its axes "
            "one after another, the units side by side on the workers, so without --jobs)."),
    )
    p.add_argument("inputs", nargs="*", metavar="BAG_OR_GLOB", help="bags, rosbag2 folders or glob patterns")
    p.add_argument("--manifest", type=Path, help="YAML (bags: [{path, topics}]) or text file (one path per line)")
    add_topic(p, "IMU topics to analyse in every bag, or all (default: all sensor_msgs/Imu topics of each bag)",
              aliases=("--topics",), several=True, default=["all"])
    p.add_argument("--spec", type=Path,
                   help="datasheet limits, YAML: {gyro: {noise_density: …, random_walk: …, bias_instability: …}, "
                        "accel: {…}} (SI units, the largest allowed values)")
    add_out(p, "batch", per_bag=False)
    p.add_argument("--workers", type=int, default=2, help="local cluster: worker processes (default: 2)")
    p.add_argument("--memory-limit", default="4GiB", help="local cluster: memory limit per worker (default: 4GiB)")
    p.add_argument("--scheduler", help="address of an existing Dask scheduler, e.g. tcp://10.0.0.5:8786")
    add_rate_option(p)
    add_analysis_options(p, "batch")
    p.set_defaults(run=run)


def _spec(path: Path | None) -> dict | None:
    from ..report.spec import read_spec

    return None if path is None else read_spec(path)


def run(args: argparse.Namespace) -> int:
    """Discover the units, run them on Dask, write the fleet table and report; 1 when a unit failed (its row and a
    line on stderr say why), else 0."""
    from ..batch import BatchOptions, BatchProgress, discover_units, open_client, run_batch
    from ..core.errors import InputError
    from ..core.timing import check_declared_rate
    from ..report.fleet import annotate, write_fleet_report, write_tables
    from ..report.spec import noise_density_limits
    from .progress import TextProgress

    if args.workers < 1:
        raise InputError(f"--workers must be >= 1, got {args.workers}")
    if args.rate is not None:  # before a cluster starts, as each unit's reader would
        check_declared_rate(args.rate)
    spec = _spec(args.spec)
    options = BatchOptions(analysis_options(args, jobs=1), rate=args.rate, temperature_topic=args.temperature_topic,
                           overbound_exports=args.overbound,
                           limits=noise_density_limits(spec) if spec else None)
    units = discover_units(list(args.inputs), list(args.topic), args.manifest)
    where = args.scheduler or f"a local cluster of {args.workers} workers on 127.0.0.1"
    print(f"{len(units)} units on {where}", flush=True)

    bar = TextProgress("batch", unit="units")

    def progress(p: BatchProgress) -> None:
        # the bar of every command on a terminal; a line per unit into a log, where the bar is not drawn
        bar(p.done + p.skipped, p.total)
        if not bar.enabled:
            print(f"  {p.done + p.skipped}/{p.total} units ({p.failed} failed, {p.skipped} unchanged and skipped, "
                  f"{p.running} running or queued), ~{p.left_s:.0f} s left [{p.elapsed_s:.0f} s]", flush=True)

    with open_client(args.scheduler, args.workers, args.memory_limit) as client, bar:
        result = run_batch(units, options, args.out, client, progress=progress)
    rows = annotate(result.rows, spec)
    paths = [*write_tables(rows, args.out),
             write_fleet_report(rows, args.out, title=f"IMU fleet: {len(units)} units", spec=spec)]
    failed = [o for o in result.outcomes if o.status == "failed"]
    for o in failed:
        print(f"failed: {o.name}: {o.error}", file=sys.stderr)
    print(f"{len(units) - len(failed)} of {len(units)} units done in {result.seconds:.0f} s; "
          + ", ".join(str(p) for p in paths))
    return 1 if failed else 0
