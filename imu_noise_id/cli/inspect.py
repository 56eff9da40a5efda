"""``imu-noise-id inspect``: what a bag holds, what its IMU topic looks like, and whether it is usable."""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from pathlib import Path

from . import add_rate_option
from .options import add_topic
from .progress import TextProgress

DESCRIPTION = """\
List the topics of a bag (ROS 1 .bag, rosbag2 directory, .db3 or .mcap), read its sensor_msgs/Imu topic and print
the number of samples, rate, duration, frame, the repairs made while reading (dropped NaN/inf samples, sorted
or duplicated stamps, gaps), the covariances the driver declares (and the noise densities they imply,
√(covariance / rate)), odometry/temperature topics found, and whether the data look static (needed by the
offline noise analysis)."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``inspect`` subcommand."""
    parser = subparsers.add_parser(
        "inspect",
        help="list a bag's topics and check its IMU data",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("bag", type=Path, metavar="BAG", help="the bag")
    add_topic(parser)
    add_rate_option(parser)
    parser.set_defaults(run=run)


def _fmt(values: Iterable[float]) -> str:
    return ", ".join(f"{v:.3g}" for v in values)


def run(args: argparse.Namespace) -> int:
    """Print the topics, the IMU summary, the repair notes and the static check."""
    import numpy as np

    from ..bag.reader import read_bag
    from ..bag.topics import list_topics
    from ..core.stillness import static_check

    topics = list_topics(args.bag)
    print(f"{args.bag}:")
    for name, (msgtype, count) in topics.items():
        print(f"  {name:40s} {msgtype:32s} {count:>10d} msgs")
    with TextProgress(f"reading {args.bag.name}") as progress:
        bag = read_bag(args.bag, imu_topic=args.topic, progress=progress, rate_hz=args.rate)
    imu = bag.imu
    duration = float(imu.t[-1] - imu.t[0])
    period = imu.sample_period()
    print(f"IMU {imu.topic} (frame {imu.frame_id!r}): {len(imu)} samples, {duration:.3f} s; rate {period.describe()}")
    if period.refusal is not None:
        print(f"  not usable as it is: {period.refusal}")
    for note in imu.notes:
        print(f"  note: {note}")
    for name, unit in (("angular_velocity", "rad/s"), ("linear_acceleration", "m/s²")):
        diag = np.diag(bag.imu_covariance.get(name, np.zeros((3, 3))))
        if not np.any(diag):
            print(f"  declared {name}_covariance: all zero (unknown)")
        elif diag[0] == -1:
            print(f"  declared {name}_covariance: -1 (not provided)")
        else:
            density = np.sqrt(np.clip(diag, 0, None) / period.rate_hz)
            print(
                f"  declared {name}_covariance diag ({_fmt(diag)}) ({unit})² "
                f"⇒ noise density √(c/f) = ({_fmt(density)}) {unit}/√Hz"
            )
    for series, what in ((bag.odom, "odometry"), (bag.temperature, "temperature")):
        if series is not None:
            print(f"{what} {series.topic}: {len(series.t)} messages")
    for note in bag.notes:
        if not note.startswith(f"{imu.topic}: "):
            print(f"  note: {note}")
    check = static_check(imu, period.value)
    if check.flags:
        print("not static (a static noise analysis of these data would be wrong):")
        for flag in check.flags:
            print(f"  - {flag}")
        if check.still_span is not None:
            print("  the longest still stretch: analyze --span {:.1f}:{:.1f}".format(*check.still_span))
    else:
        print("looks static: fine for the offline noise analysis")
    for note in check.notes:
        print(f"  note: {note}")
    return 0
