"""``imu-noise-id analyze BAG``: offline noise analysis of a static IMU recording.

Parses the options, reads the bag once (IMU and temperature), runs :func:`imu_noise_id.pipelines.analyze.analyze`
and writes its result with :func:`imu_noise_id.report.analysis.write_analysis`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from . import add_rate_option, results_folder

DEFAULT_OUT = "imu_noise_id_results"


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``analyze`` parser."""
    p = subparsers.add_parser(
        "analyze",
        help="noise analysis of a static IMU bag: Allan family, EM model fits, closed loop (imu.yaml, model.yaml)",
        description=(
            "Read sensor_msgs/Imu from a static recording (ROS 1 .bag, rosbag2 sqlite3 or mcap, or an .npz with t, "
            "gyro, accel), compute the Allan, Hadamard, total and modified Allan variances of the six axes with "
            "confidence intervals, read the white-noise density (-1/2 slope at tau = 1 s) and random walk (+1/2 "
            "slope at tau = 3 s), and write DIR/imu.yaml (Kalibr format), DIR/allan.csv (+ hadamard.csv, total.csv, "
            "modified.csv) and DIR/allan.png; then fit error models per axis with the constrained EM algorithm "
            "(model selection by BIC, 95 percent confidence intervals, recording-length advice: DIR/model.yaml) and "
            "close the loop on the residuals (DIR/report.html). The IMU must be at rest for the whole recording."
        ),
    )
    p.add_argument("bag", type=Path, help="bag file or rosbag2 directory")
    p.add_argument("--topic", help="sensor_msgs/Imu topic (needed only when the bag has several)")
    p.add_argument("--out", type=Path, default=Path(DEFAULT_OUT), help=f"output directory (default: {DEFAULT_OUT})")
    add_rate_option(p)
    p.add_argument("--per-decade", type=int, default=8, help="averaging times per decade of tau (default: 8)")
    p.add_argument("--confidence", type=float, default=0.95, help="confidence level of the intervals (default: 0.95)")
    p.add_argument(
        "--model", default="auto",
        help="EM model fit per axis after the Allan stage: 'auto' (default: BIC over the default candidates), a "
        "structure such as 'WN+GM+RW', or 'none' (Allan only). Writes DIR/model.yaml and DIR/allan_model.png "
        "and puts the model's noise density / random walk into imu.yaml (Allan values kept as *_allan)",
    )
    p.add_argument(
        "--allow-motion", action="store_true",
        help="analyse even if the static check finds motion (its findings become warnings)",
    )
    p.add_argument(
        "--no-loop", action="store_true",
        help="skip the closed loop that follows the model fit (residual diagnosis: adds missing GM/RW/RR/QN, "
        "sinusoids, temperature, steps, outliers one at a time while BIC improves; writes a 'loop:' list per "
        "axis into model.yaml and DIR/report.html). It runs by default unless --model none",
    )
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Read, analyse, write, report. Input problems raise InputError (exit 2)."""
    from ..bag.reader import read_static
    from ..pipelines.analyze import AnalyzeOptions, ModelStage, analyze
    from ..report.analysis import write_analysis
    from ..report.console import final_table, summary_table
    from .progress import TextProgress

    options = AnalyzeOptions(per_decade=args.per_decade, confidence=args.confidence, allow_motion=args.allow_motion,
                             models=ModelStage(args.model), loop=not args.no_loop)
    with TextProgress(f"reading {args.bag.name}") as progress:
        recording = read_static(args.bag, topic=args.topic, progress=progress, rate_hz=args.rate)
    with TextProgress("Allan-family variances") as progress:
        result = analyze(recording.imu, recording.temperature, options, progress=progress, on_axis=_print_axis)
    for warning in result.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    meta = {"source": str(args.bag), "topic": recording.imu.topic, "command": "analyze", "model": args.model,
            "notes": recording.notes}
    folder = results_folder(args, str(args.bag), recording.imu.topic)
    with folder as staging:
        paths = write_analysis(result, staging, rostopic=recording.imu.topic, meta=meta,
                               title=f"IMU noise analysis: {args.bag.name}")
    folder.report()
    print(summary_table(result.static), flush=True)
    if result.finals:
        print(final_table(result.finals), flush=True)
    for w in result.static.warnings:
        print(f"warning: {w}", file=sys.stderr)
    print(f"results in {args.out}/: " + ", ".join(paths))
    return 0


def _print_axis(axis: str, fit, loop) -> None:
    from ..report.console import fit_line, loop_line

    print(fit_line(axis, fit), flush=True)
    if loop is not None:
        print(loop_line(axis, loop), flush=True)
