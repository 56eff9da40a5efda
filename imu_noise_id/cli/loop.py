"""``imu-noise-id loop BAG``: the closed loop on chosen axes of a static recording; writes ``DIR/model.yaml``
(``loop:`` per axis) and ``DIR/report.html``."""

from __future__ import annotations

import argparse
from pathlib import Path

from . import add_rate_option, print_notes, results_folder
from .options import add_axis, add_out, add_topic, model_spec

#: The effects the loop adds, for its help (equal to the loop's STATE/EXOG/CLEANING_EFFECTS: ``test_cli_style``).
LOOP_EFFECTS = ("GM", "RW", "RR", "QN", "OSC", "LPF", "MA", "BI", "SIN", "TEMP", "STEP", "OUTLIERS")


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``loop`` parser."""
    p = subparsers.add_parser(
        "loop",
        help=f"closed loop: find the effects the noise model misses ({', '.join(LOOP_EFFECTS)})",
        description=(
            "Fit a starting noise model to each chosen axis of a static bag, test its residuals (standardised "
            "innovations, Allan variance against the model's) for missing effects, add the most significant one "
            "(state-space component, deterministic regressor or outlier removal), refit, and keep it only if the "
            "BIC improves and its evidence is gone; repeat until the residuals pass or nothing improves. Writes "
            "DIR/model.yaml (a 'loop:' list per axis with the errors before and after each step) and "
            "DIR/report.html (self-contained, with before/after Allan plots and residual ACF/PSD). A "
            "sensor_msgs/Temperature topic in the bag enables the thermal-bias test."
        ),
    )
    p.add_argument("bag", type=Path, help="bag file or rosbag2 directory")
    add_topic(p)
    p.add_argument("--temperature-topic", help="sensor_msgs/Temperature topic (default: the bag's only one)")
    p.add_argument("--start", default="WN+RW", type=model_spec(), help="starting model structure (default: WN+RW)")
    add_axis(p, aliases=("--axes",))
    p.add_argument("--max-steps", type=int, default=None,
                   help="most effects added per axis (default: the loop's, as in analyze; docs/loop.md)")
    p.add_argument("--alpha", type=float, default=0.01, help="level of every detector (default: 0.01)")
    add_out(p, "loop")
    add_rate_option(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Read the bag, run the loop axis by axis (progress on stderr), write model.yaml and report.html."""
    from ..bag.reader import read_static
    from ..core.errors import InputError
    from ..pipelines.loop import ImuLoop
    from ..report.console import loop_line, loop_table
    from ..report.html import write_loop_report
    from ..report.model_yaml import write_model_yaml
    from .options import parse_axes
    from .progress import TextProgress

    axes = parse_axes(args.axis)
    if (args.max_steps is not None and args.max_steps < 0) or not 0 < args.alpha < 1:
        raise InputError("--max-steps must be >= 0 and --alpha in (0, 1)")
    with TextProgress(f"reading {args.bag.name}") as progress:
        recording = read_static(args.bag, topic=args.topic, temperature_topic=args.temperature_topic,
                                progress=progress, rate_hz=args.rate)
    print_notes(recording.notes)
    steps = {} if args.max_steps is None else {"max_steps": args.max_steps}
    loop = ImuLoop(recording.imu, recording.temperature, alpha=args.alpha, **steps)
    results = {}
    with TextProgress(f"closed loop from {args.start}", unit="axes") as progress:
        progress(0, len(axes))
        for axis in axes:
            results[axis] = loop.run(axis, args.start)
            progress.echo(loop_line(axis, results[axis]))
            progress(len(results), len(axes))
    print(loop_table(results), flush=True)
    meta = {"source": str(args.bag), "topic": recording.imu.topic, "command": "loop", "start": args.start,
            "notes": recording.notes}
    folder = results_folder(args, str(args.bag), recording.imu.topic)
    with folder as staging:
        paths = [write_model_yaml(staging / "model.yaml", {}, results, meta),
                 write_loop_report(staging / "report.html", results, title=f"closed loop: {args.bag.name}")]
    folder.report()
    print(f"results in {args.out}/: " + ", ".join(p.name for p in paths))
    return 0
