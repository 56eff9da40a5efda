"""``imu-noise-id analyze BAG``: offline noise analysis of a static IMU recording (one read of the bag,
:func:`imu_noise_id.pipelines.analyze.analyze`, :func:`imu_noise_id.report.analysis.write_analysis`)."""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from . import add_rate_option, results_folder
from .options import add_analysis_options, add_out, add_topic, analysis_options
from .progress import TextProgress

if TYPE_CHECKING:
    from ..core.estimation.em.results import FitResult
    from ..pipelines.analyze import AnalyzeOptions
    from ..pipelines.loop import LoopResult


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
    add_analysis_options(p, "analyze")
    p.set_defaults(run=run)


def run_analysis(args: argparse.Namespace, options: AnalyzeOptions,
                 on_axis: Callable[[str, FitResult, LoopResult | None, TextProgress], None]) -> tuple:
    """The one runner of ``analyze``, ``batch``'s units aside, ``fit`` and ``loop``: refuse a record this machine
    cannot analyse before it is decoded (:mod:`.memory`), read the bag once, run
    :func:`~imu_noise_id.pipelines.analyze.analyze` with ``options`` (progress on stderr; the workers read the
    recording from files), print its warnings. ``on_axis(axis, fit, loop, bar)`` as each axis is done. Returns the
    bag's contents and the :class:`~imu_noise_id.pipelines.analyze.AnalysisResult`."""
    from ..bag.reader import read_static
    from ..bag.topics import IMU_TYPE
    from ..pipelines.analyze import MappedImu, analyze, worker_processes
    from .memory import available_bytes, check_fits

    n_axes = len(options.axes)

    def fits_in_memory(msgtype: str, topic: str, count: int, bag_span_s: float | None) -> None:
        if msgtype == IMU_TYPE and options.models.enabled:
            jobs = worker_processes(options.jobs, count, n_axes)
            check_fits(topic, count, bag_span_s, span=options.span, workers=jobs if jobs > 1 else 0,
                       available=available_bytes())

    with TextProgress(f"reading {Path(args.bag).name}") as progress:
        recording = read_static(args.bag, topic=args.topic, temperature_topic=getattr(args, "temperature_topic", None),
                                progress=progress, rate_hz=args.rate, before_decoding=fits_in_memory)
    allan = TextProgress("Allan-family variances")
    model = options.models.model
    stage = "model selection" if model == "auto" else f"fitting {model}"
    if options.loop and options.models.enabled:
        stage = f"closed loop from {model}" if args.command == "loop" else f"{stage} and closed loop"
    models = TextProgress(stage, unit="axes")
    done: list[str] = []

    def allan_progress(k: int, total: int) -> None:
        allan(k, total)
        if k == total and options.models.enabled:  # the Allan stage is over: the model stage's bar takes over
            allan.close()
            models(0, n_axes)

    def axis_done(axis: str, fit: FitResult, loop: LoopResult | None) -> None:
        done.append(axis)
        on_axis(axis, fit, loop, models)
        models(len(done), n_axes)

    with allan, models, tempfile.TemporaryDirectory(prefix="imu_noise_id_") as mapped:
        imu = recording.imu
        if options.span is None and worker_processes(options.jobs, len(imu), n_axes) > 1:
            # the workers and this process read one copy from files; the decoded arrays are let go
            try:
                imu = MappedImu.write(imu, Path(mapped))
            except OSError as exc:
                print(f"note: the recording stays in memory, one copy per process: it could not be written to "
                      f"{mapped} ({exc.strerror or exc}); set TMPDIR to a folder with room to save memory",
                      file=sys.stderr)
            else:
                recording = replace(recording, imu=imu.series)
        result = analyze(imu, recording.temperature, options, progress=allan_progress, on_axis=axis_done)
    for warning in result.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    return recording, result


def run(args: argparse.Namespace) -> int:
    """Read, analyse, write, report (``analyze``, and ``loop``: the same with the model given and the loop's table).
    Input problems raise InputError (exit 2)."""
    from ..report.analysis import write_analysis
    from ..report.console import (
        comparison_table,
        final_table,
        fit_line,
        loop_line,
        loop_table,
        overbound_lines,
        record_length_lines,
        summary_table,
    )

    options = analysis_options(args)

    def on_axis(axis: str, fit: FitResult, loop: LoopResult | None, bar: TextProgress) -> None:
        bar.echo(fit_line(axis, fit))
        if loop is not None:
            bar.echo(loop_line(axis, loop, fit.model))

    recording, result = run_analysis(args, options, on_axis)
    meta = {"source": str(args.bag), "topic": recording.imu.topic, "command": args.command, "model": args.model,
            "estimator": options.models.estimator, "notes": recording.notes}
    folder = results_folder(args, str(args.bag), recording.imu.topic)
    with folder as staging:
        paths = write_analysis(result, staging, meta=meta, title=f"IMU noise analysis: {Path(args.bag).name}",
                               overbound_exports=getattr(args, "overbound", False),
                               processes=options.jobs or len(os.sched_getaffinity(0)))
    folder.report()
    print(summary_table(result.static, result.numbers), flush=True)
    if result.loops and args.command == "loop":
        print(loop_table(result.loops), flush=True)
    if result.finals:
        print(final_table(result.finals, result.static, result.numbers), flush=True)
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
