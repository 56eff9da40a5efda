"""``imu-noise-id analyze BAG``: offline noise analysis of a static IMU recording.

Parses the options, reads the bag once (IMU and temperature), runs :func:`imu_noise_id.pipelines.analyze.analyze`
and writes its result with :func:`imu_noise_id.report.analysis.write_analysis`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..core.estimation.overbound import DEFAULT_HORIZON_S
from . import add_rate_option, results_folder
from .options import add_out, add_topic, model_spec, span_spec


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
    add_topic(p)
    add_out(p, "analyze")
    add_rate_option(p)
    p.add_argument("--per-decade", type=int, default=8, help="averaging times per decade of tau (default: 8)")
    p.add_argument("--confidence", type=float, default=0.95, help="confidence level of the intervals (default: 0.95)")
    p.add_argument(
        "--model", default="auto", type=model_spec("auto", "none"),
        help="EM model fit per axis after the Allan stage: 'auto' (default: BIC over the default candidates), a "
        "structure such as 'WN+GM+RW', or 'none' (Allan only). Writes DIR/model.yaml and DIR/allan_model.png "
        "and puts the model's noise density / random walk into imu.yaml (Allan values kept as *_allan)",
    )
    p.add_argument(
        "--estimator", choices=("auto", "em", "gmwm", "both"), default="auto",
        help="model estimator: 'em' (maximum likelihood), 'gmwm' (wavelet variance; no closed loop), 'both' (GMWM, "
        "then EM from its estimates, compared parameter by parameter) or 'auto' (default: EM, GMWM on records too "
        "long for the EM, with a warning)",
    )
    p.add_argument("--robust", action="store_true",
                   help="GMWM: fit the robust wavelet variance (bounded influence; for records with outliers)")
    p.add_argument(
        "--allow-motion", action="store_true",
        help="analyse even if the static check finds motion (its findings become warnings)",
    )
    p.add_argument(
        "--span", type=span_spec, default=None, metavar="START:END",
        help="analyse only the samples from START to END seconds after the first one (START: or :END for the "
        "rest), e.g. the still stretch the static check suggests around a moment of motion")
    p.add_argument(
        "--horizon", type=float, default=DEFAULT_HORIZON_S, metavar="S",
        help="longest time scale [s] the overbound must cover: the smallest WN+RW whose Allan variance lies above "
        "the data's upper bound and the final model from the sampling period to S (imu.yaml 'overbound:', "
        f"report.html; default {DEFAULT_HORIZON_S:g})")
    p.add_argument("--overbound", action="store_true",
                   help="also write the exports of the overbound's values into DIR/exports/overbound/")
    p.add_argument(
        "--no-loop", action="store_true",
        help="skip the closed loop that follows the model fit (residual diagnosis: adds missing GM/RW/RR/QN, "
        "sinusoids, temperature, steps, outliers one at a time while BIC improves; writes a 'loop:' list per "
        "axis into model.yaml and DIR/report.html). It runs by default unless --model none",
    )
    p.add_argument(
        "--jobs", type=int, default=0, metavar="N",
        help="worker processes for the per-axis model stage and loop, one axis each (default 0: one per available "
        "core on records of 100000 samples or more; 1: none). The results are the same; peak memory adds up over "
        "the workers")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Read, analyse, write, report. Input problems raise InputError (exit 2)."""
    from ..bag.reader import read_static
    from ..core.axes import AXES
    from ..core.estimation.gmwm import GmwmOptions
    from ..pipelines.analyze import AnalyzeOptions, ModelStage, analyze
    from ..report.analysis import write_analysis
    from ..report.console import (
        comparison_table,
        final_table,
        fit_line,
        loop_line,
        overbound_lines,
        record_length_lines,
        summary_table,
    )
    from .progress import TextProgress

    options = AnalyzeOptions(per_decade=args.per_decade, confidence=args.confidence, allow_motion=args.allow_motion,
                             models=ModelStage(args.model, estimator=args.estimator,
                                               gmwm=GmwmOptions(robust=args.robust)),
                             loop=not args.no_loop, horizon_s=args.horizon, jobs=args.jobs, span=args.span)
    with TextProgress(f"reading {args.bag.name}") as progress:
        recording = read_static(args.bag, topic=args.topic, progress=progress, rate_hz=args.rate)
    allan = TextProgress("Allan-family variances")
    stage = "model selection" if args.model == "auto" else f"fitting {args.model}"
    models = TextProgress(stage + (" and closed loop" if options.loop else ""), unit="axes")
    n_axes = len(AXES)
    done: list[str] = []

    def allan_progress(k: int, total: int) -> None:
        allan(k, total)
        if k == total and options.models.enabled:  # the Allan stage is over: the model stage's bar takes over
            allan.close()
            models(0, n_axes)

    def on_axis(axis: str, fit, loop) -> None:
        done.append(axis)
        models.echo(fit_line(axis, fit))
        if loop is not None:
            models.echo(loop_line(axis, loop, fit.model))
        models(len(done), n_axes)

    with allan, models:
        result = analyze(recording.imu, recording.temperature, options, progress=allan_progress, on_axis=on_axis)
    for warning in result.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    meta = {"source": str(args.bag), "topic": recording.imu.topic, "command": "analyze", "model": args.model,
            "estimator": args.estimator, "notes": recording.notes}
    folder = results_folder(args, str(args.bag), recording.imu.topic)
    with folder as staging:
        paths = write_analysis(result, staging, rostopic=recording.imu.topic, meta=meta,
                               title=f"IMU noise analysis: {args.bag.name}", overbound_exports=args.overbound)
    folder.report()
    print(summary_table(result.static), flush=True)
    if result.finals:
        print(final_table(result.finals), flush=True)
    if any(m.comparison is not None for m in result.models.values()):
        print(comparison_table(result.models), flush=True)
    finals = {axis: final.fit for axis, final in result.finals.items()} or result.fits
    names = {axis: final.model for axis, final in result.finals.items()}
    for line in [*record_length_lines(finals, names), *overbound_lines(result.overbounds)]:
        print(line, flush=True)
    for w in result.static.warnings:
        print(f"warning: {w}", file=sys.stderr)
    print(f"results in {args.out}/: " + ", ".join(paths))
    return 0
