"""``imu-noise-id identify BAG``: recursive Bayesian hypothesis probabilities per axis (paper 002)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from . import add_rate_option, print_notes, results_folder
from .options import add_axis, add_out, add_topic, span_spec


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "identify",
        help="which error model fits each axis: Bayesian hypothesis probabilities vs time",
        description=(
            "Run the recursive Bayesian hypothesis bank (Stepanov & Motorin 2019) on a static IMU recording: "
            "for every axis, the posterior probability of each error-model hypothesis (default: WN+RW vs "
            "WN+GM, each with a constant bias) as data accumulate, the decision once one reaches gamma, and "
            "the parameter estimates with their relative standard deviations. Writes DIR/hypotheses.yaml, "
            "DIR/hypotheses_probabilities.csv and DIR/hypotheses_probabilities.png."
        ),
    )
    p.add_argument("bag", type=Path,
                   help="rosbag2 directory, .mcap/.db3 file or ROS 1 .bag with a static IMU recording")
    p.add_argument("--hypotheses", metavar="FILE", default=None,
                   help="hypothesis set YAML (default: config/hypotheses_default.yaml)")
    add_axis(p)
    add_topic(p)
    add_out(p, "identify")
    p.add_argument("--refine", type=int, default=2, metavar="N",
                   help="grid-refinement passes: rerun with grids re-centred on the posterior (default: %(default)s)")
    p.add_argument("--no-plot", action="store_true", help="skip the PNG plot")
    p.add_argument("--allow-motion", action="store_true",
                   help="identify even if the static check finds motion (its findings become notes)")
    p.add_argument("--span", type=span_spec, default=None, metavar="START:END",
                   help="identify only the samples from START to END seconds after the first one, e.g. a still "
                        "stretch")
    add_rate_option(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Check the options, read the bag, run the bank axis by axis (progress on stderr), write the results."""
    from ..bag.reader import read_imu
    from ..pipelines.identify import identify
    from ..report.hypotheses_yaml import axis_entry, decision_line, write_identification
    from ..resources import read_hypotheses_file
    from .options import parse_axes
    from .progress import TextProgress

    axes = parse_axes(args.axis)
    hypotheses, source = read_hypotheses_file(args.hypotheses)
    with TextProgress(f"reading {args.bag.name}") as progress:
        series = read_imu(args.bag, topic=args.topic, progress=progress, rate_hz=args.rate)
    if args.span is not None:
        series = series.between(*args.span)
    with TextProgress("hypothesis bank", unit="axes") as progress:
        progress(0, len(axes))
        res = identify(series, axes, hypotheses, source, args.refine, progress=progress,
                       allow_motion=args.allow_motion, origin_s=args.span[0] if args.span is not None else 0.0)
    print_notes(res.notes)
    out = args.out
    folder = results_folder(args, str(args.bag), series.topic)
    with folder as staging:
        write_identification(res, staging)
        if not args.no_plot:
            from ..report.hypotheses_plots import plot_identify

            plot_identify(res, staging / "hypotheses_probabilities.png")
    folder.report()
    for axis, e in res.axes.items():
        entry = axis_entry(axis, e)
        print(decision_line(axis, entry))
        for g in e.result.final.long_memory:
            if g.text() not in entry["decision_note"]:
                print(f"  {g.text()}")
    print(f"wrote {out / 'hypotheses.yaml'}")
    return 0
