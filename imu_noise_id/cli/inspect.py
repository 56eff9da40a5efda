"""``imu-noise-id inspect``: what a bag holds, what its IMU topic looks like, and whether it is usable."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

DESCRIPTION = """\
List the topics of a bag (ROS 1 .bag, rosbag2 directory, .db3 or .mcap), read its sensor_msgs/Imu topic and print
the number of samples, rate, duration, frame, the repairs made while reading (dropped NaN/inf samples, sorted
or duplicated stamps, gaps) and whether the data look static (needed by the offline noise analysis)."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``inspect`` subcommand."""
    parser = subparsers.add_parser(
        "inspect",
        help="list a bag's topics and check its IMU data",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("bag", type=Path, metavar="BAG", help="the bag")
    parser.add_argument("--topic", default=None, metavar="T", help="Imu topic (needed when the bag has several)")
    parser.set_defaults(run=run)


def progress_printer(label: str) -> object:
    """A ``progress(done, total)`` callback drawing a one-line bar on stderr when it is a terminal."""
    if not sys.stderr.isatty():
        return None

    def show(done: int, total: int) -> None:
        width = 30
        frac = done / total if total else 1.0
        bar = "#" * round(width * min(frac, 1.0))
        end = "\n" if done >= total else ""
        print(f"\r{label} [{bar:<{width}}] {done}/{total}", end=end, file=sys.stderr, flush=True)

    return show


def run(args: argparse.Namespace) -> int:
    """Print the topics, the IMU summary, the repair notes and the static check."""
    from ..bag.reader import list_topics, read_imu
    from ..core.quality import static_check

    topics = list_topics(args.bag)
    print(f"{args.bag}:")
    for name, (msgtype, count) in topics.items():
        print(f"  {name:40s} {msgtype:32s} {count:>10d} msgs")
    imu = read_imu(args.bag, args.topic, progress=progress_printer("reading"))
    duration = float(imu.t[-1] - imu.t[0])
    print(f"IMU {imu.topic} (frame {imu.frame_id!r}): {len(imu)} samples, {imu.rate:.6g} Hz (median), {duration:.3f} s")
    for note in imu.notes:
        print(f"  note: {note}")
    flags = static_check(imu)
    if flags:
        print("not static (a static noise analysis of these data would be wrong):")
        for flag in flags:
            print(f"  - {flag}")
    else:
        print("looks static: fine for the offline noise analysis")
    return 0
