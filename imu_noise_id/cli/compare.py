"""``imu-noise-id compare``: a static recording against a reference analysis, one table and one exit code: 0 within,
1 degraded, 2 input error."""

from __future__ import annotations

import argparse
from pathlib import Path

from . import add_rate_option
from .options import add_topic, span_spec
from .progress import TextProgress

DESCRIPTION = """\
Test a static recording of an IMU against a reference: the results folder `imu-noise-id analyze` wrote for this
unit at its calibration (or for a typical unit of the fleet). Per axis: the white-noise level (a CUSUM on pair
differences against the reference's N and its interval, both ways, at --false-alarms-per-hour), a bias step inside
the recording and a new spectral line (both under the reference's final model). Prints one table; exit code 0 when
every axis is within its reference, 1 when one is degraded (end-of-line testing), 2 on input errors."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``compare`` subcommand."""
    parser = subparsers.add_parser("compare", help="test a recording against a reference analysis (exit 1: degraded)",
                                   description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("bag", type=Path, metavar="BAG", help="the recording (static)")
    parser.add_argument("--reference", type=Path, required=True, metavar="DIR",
                        help="results folder of `analyze` (or its imu.yaml) to compare against")
    add_topic(parser)
    add_rate_option(parser)
    parser.add_argument("--span", type=span_spec, default=None, metavar="START:END",
                        help="compare only this part of the recording [s from its first sample]")
    parser.add_argument("--ratio", type=float, default=1.5, metavar="R",
                        help="noise-density ratio (live/reference, either way) the level test is tuned to (default "
                             "1.5)")
    parser.add_argument("--false-alarms-per-hour", type=float, default=0.1, metavar="L",
                        help="false alarms per hour of data the whole unit allows, shared among its axes and "
                             "tests (default 0.1)")
    parser.add_argument("--other-topic", action="store_true",
                        help="compare against a reference made from another topic (another IMU, e.g. the fleet's "
                             "typical unit); without it that is refused")
    parser.add_argument("--spec", type=Path, default=None, metavar="FILE",
                        help="datasheet limits, YAML as batch --spec reads ({gyro: {noise_density: …}, accel: {…}}, "
                             "SI): an axis whose noise density is beyond its sensor's limit is degraded too")
    parser.set_defaults(run=run)


def table(comparison, reference) -> str:
    """One line per axis: the reference's N, the live/reference ratio with its interval, and what differs."""
    lines = [f"{'axis':8s} {'reference N':>12s}  {'live/ref N':>10s} {'95 %':>17s}  status"]
    for axis, c in comparison.axes.items():
        ref = reference.axes[axis]
        lo, hi = c.noise.ratio_ci
        what = "; ".join(c.findings()) or "within"
        lines.append(f"{axis:8s} {ref.noise_density:12.4g}  {c.noise.ratio:10.3f} [{lo:.3f}, {hi:.3f}]  "
                     f"{'DEGRADED: ' if c.degraded else ''}{what}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Print the table; 1 when an axis is degraded."""
    from ..bag.reader import read_bag
    from ..pipelines.compare import compare
    from ..report.reference import read_reference
    from ..report.spec import noise_density_limits, read_spec

    if not args.ratio > 1.0 or not args.false_alarms_per_hour > 0:
        from ..core.errors import InputError
        raise InputError("--ratio must be > 1 and --false-alarms-per-hour > 0")
    reference = read_reference(args.reference)
    limits = noise_density_limits(read_spec(args.spec)) if args.spec is not None else {}
    with TextProgress(f"reading {args.bag.name}") as progress:
        imu = read_bag(args.bag, imu_topic=args.topic, progress=progress, rate_hz=args.rate).imu
    if args.span is not None:
        imu = imu.between(*args.span)
    result = compare(imu, reference.axes, reference.rate_hz, reference.topic, ratio=args.ratio,
                     false_alarms_per_hour=args.false_alarms_per_hour, limits=limits, other_topic=args.other_topic)
    print(f"{args.bag} ({result.duration_s:.0f} s) against {reference.source}:")
    for note in result.notes + [f"{axis}: {n}" for axis, c in result.axes.items() for n in c.notes]:
        print(f"note: {note}")
    print(table(result, reference))
    degraded = result.degraded
    print(f"{'DEGRADED: ' + ', '.join(degraded) if degraded else 'within the reference'} (at "
          f"{args.false_alarms_per_hour:g} false alarms per hour for the unit)")
    return 1 if degraded else 0
