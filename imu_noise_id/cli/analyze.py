"""``imu-noise-id analyze BAG``: offline noise analysis of a static IMU recording.

Stages (each a function): read → Allan → EM model fit (``--model``) → closed loop (unless ``--no-loop``):
read the bag → Allan-family variances and slope parameters (:func:`imu_noise_id.pipelines.analysis.analyze_static`)
→ write ``imu.yaml``, the variance CSVs and ``allan.png`` → print the summary and where the results are.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

DEFAULT_OUT = "imu_noise_id_results"


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``analyze`` parser."""
    p = subparsers.add_parser(
        "analyze",
        help="noise analysis of a static IMU bag: Allan family, EM model fits, closed loop (imu.yaml, model.yaml)",
        description=(
            "Read sensor_msgs/Imu from a static recording (ROS 1 .bag, rosbag2 sqlite3 or mcap), compute the "
            "Allan, Hadamard, total and modified Allan variances of the six axes with confidence intervals, read "
            "the white-noise density (-1/2 slope at tau = 1 s) and random walk (+1/2 slope at tau = 3 s), and "
            "write DIR/imu.yaml (Kalibr format), DIR/allan.csv (+ hadamard.csv, total.csv, modified.csv) and "
            "DIR/allan.png; then fit error models per axis with the constrained EM algorithm (model selection by BIC, "
            "95 %% confidence intervals, recording-length advice: DIR/model.yaml) and close the loop on the "
            "residuals (DIR/report.html). The IMU must be at rest for the whole recording."
        ),
    )
    p.add_argument("bag", type=Path, help="bag file or rosbag2 directory")
    p.add_argument("--topic", help="sensor_msgs/Imu topic (needed only when the bag has several)")
    p.add_argument("--out", type=Path, default=Path(DEFAULT_OUT), help=f"output directory (default: {DEFAULT_OUT})")
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


def _read(args: argparse.Namespace):
    from ..bag.reader import read_imu
    from .progress import TextProgress

    progress = TextProgress(f"reading {args.bag.name}")
    try:
        return read_imu(args.bag, topic=args.topic, progress=progress)
    finally:
        progress.close()


def _allan_stage(imu, args: argparse.Namespace):
    from ..pipelines.analysis import analyze_static
    from .progress import TextProgress

    progress = TextProgress("Allan-family variances")
    try:
        return analyze_static(
            imu, per_decade=args.per_decade, confidence=args.confidence, allow_motion=args.allow_motion,
            progress=progress,
        )
    finally:
        progress.close()


def _em_stage(imu, result, args: argparse.Namespace) -> dict:
    """Constrained-EM / maximum-likelihood fit of every axis (issue 3), then model.yaml, allan_model.png and
    the model values in imu.yaml."""
    from ..report.model_outputs import write_model_outputs
    from .fit import fit_axes

    fits, selections = fit_axes(imu, args.model, list(result.axes))
    allan = result.variances["allan"]
    avar = {axis: (allan.tau, allan.variance[:, j]) for j, axis in enumerate(result.axes)}
    return write_model_outputs(args.out, fits, selections, avar,
                               meta={"source": str(args.bag), "topic": imu.topic, "command": "analyze",
                                     "model": args.model})


def _loop_stage(imu, args: argparse.Namespace) -> dict:
    """Closed loop (issue 7) from each axis's fitted model in DIR/model.yaml: model.yaml ``loop:`` + report.html."""
    import yaml

    from ..bag.reader import read_temperature
    from ..core.errors import InputError
    from .loop import loop_stage

    models = yaml.safe_load((args.out / "model.yaml").read_text())["axes"]
    start = {axis: entry["model"] for axis, entry in models.items()}
    try:
        temperature = read_temperature(args.bag)
    except InputError as exc:
        print(f"warning: closed loop without temperature: {exc}", file=sys.stderr)
        temperature = None
    try:
        results, paths, factor = loop_stage(imu, temperature, args.out, start=start, axes=tuple(start),
                                            title=f"closed loop: {args.bag.name}")
    except InputError as exc:
        print(f"warning: closed loop skipped: {exc}", file=sys.stderr)
        return {}
    for axis, r in results.items():
        print(f"{axis}: loop {r.steps[0].model} -> {r.final.model}: {r.verdict}", flush=True)
    if factor > 1:
        print(f"closed loop ran on {factor}-sample block averages", flush=True)
    return {"loop_report": paths["report"]}


def run(args: argparse.Namespace) -> int:
    """Read, analyse, write, report. Input problems raise InputError (exit 2)."""
    from ..core.errors import InputError
    from ..report.outputs import summary_table, write_static_outputs

    if not 0.0 < args.confidence < 1.0:
        raise InputError(f"--confidence must lie in (0, 1), got {args.confidence}")
    if args.per_decade < 1:
        raise InputError(f"--per-decade must be >= 1, got {args.per_decade}")
    imu = _read(args)
    result = _allan_stage(imu, args)
    paths = write_static_outputs(result, args.out, rostopic=imu.topic)
    if args.model != "none":
        paths.update(_em_stage(imu, result, args))
        if not args.no_loop:
            paths.update(_loop_stage(imu, args))
    print(summary_table(result), flush=True)
    for w in result.warnings:
        print(f"warning: {w}", file=sys.stderr)
    print(f"results in {args.out}/: " + ", ".join(paths))
    return 0
