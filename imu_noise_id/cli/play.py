"""``imu-noise-id play BAG``: publish a bag's Imu, Odometry and Temperature messages with their original timing
(:func:`imu_noise_id.ros.play.play_bag`)."""

from __future__ import annotations

import argparse
import contextlib
from pathlib import Path

from ..core.errors import InputError
from .options import add_topic


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``play`` subcommand."""
    parser = subparsers.add_parser(
        "play",
        help="publish a bag's IMU, odometry and temperature messages with their original timing",
        description="Publish the sensor_msgs/Imu, nav_msgs/Odometry and sensor_msgs/Temperature messages of a "
        "bag (rosbag2 directory, .db3, .mcap or ROS 1 .bag) on their recorded topics with their original timing "
        "(a stand-in for `ros2 bag play`, which pip installs lack). Header stamps are published unchanged.",
    )
    parser.add_argument("bag", type=Path, help="the bag to play")
    parser.add_argument("--rate", type=float, default=1.0, help="playback speed factor (default 1; 2 = twice as fast)")
    parser.add_argument("--loop", action="store_true", help="start again at the end, until interrupted")
    add_topic(parser, "play only these topics (default: all Imu, Odometry and Temperature topics)",
              aliases=("--topics",), several=True)
    parser.add_argument("--remap", nargs="+", default=[], metavar="FROM:=TO",
                        help="publish topic FROM under the name TO, e.g. /imu:=/imu/data")
    parser.add_argument("--delay", type=float, default=2.0,
                        help="wait up to this many seconds for every topic to have a subscriber before the first "
                        "message, so that nothing is lost to DDS discovery (default 2)")
    parser.add_argument("--quiet", action="store_true", help="no progress line")
    parser.set_defaults(run=run)


def _remaps(items: list[str]) -> dict[str, str]:
    out = {}
    for item in items:
        if ":=" not in item:
            raise InputError(f"--remap {item!r}: expected FROM:=TO, e.g. /imu:=/imu/data")
        src, dst = item.split(":=", 1)
        out[src] = dst
    return out


def run(args: argparse.Namespace) -> int:
    """Play the bag; returns 0 at the end (or on Ctrl-C with --loop)."""
    if not (args.rate > 0):
        raise InputError(f"--rate must be > 0, got {args.rate}")
    if not (args.delay >= 0):
        raise InputError(f"--delay must be >= 0 s, got {args.delay}")
    remap = _remaps(args.remap)
    from ..ros.play import play_bag

    with contextlib.suppress(KeyboardInterrupt):  # Ctrl-C ends a --loop
        play_bag(args.bag, rate=args.rate, loop=args.loop, topics=args.topic, remap=remap, delay=args.delay,
                 quiet=args.quiet)
    return 0
