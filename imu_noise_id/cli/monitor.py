"""``imu-noise-id monitor``: a live terminal view of a running ``imu_noise_id_node`` (:mod:`imu_noise_id.ros.monitor`);
``--once`` waits for the outputs and prints one snapshot."""

from __future__ import annotations

import argparse
import contextlib

from ..core.errors import InputError


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``monitor`` subcommand."""
    parser = subparsers.add_parser(
        "monitor",
        help="live terminal view of a running imu_noise_id_node",
        description="Show a running imu_noise_id_node's outputs — biases with their uncertainty, noise figures, "
        "hypothesis probabilities and its diagnostics — refreshed in place (ANSI terminal).",
    )
    parser.add_argument("--node", default="/imu_noise_id_node",
                        help="fully qualified node name (default /imu_noise_id_node)")
    parser.add_argument("--once", action="store_true", help="wait for the outputs, print one snapshot and exit")
    parser.add_argument("--period", type=float, default=0.5, help="refresh period [s] (default 0.5)")
    parser.add_argument("--timeout", type=float, default=10.0,
                        help="with --once: give up after this many seconds without outputs (default 10)")
    parser.add_argument("--duration", type=float, default=0.0, help="stop after this many seconds (0: until Ctrl-C)")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Show the view until Ctrl-C / ``--duration`` (or one snapshot with ``--once``)."""
    node = args.node if args.node.startswith("/") else "/" + args.node
    if not (args.period > 0 and args.timeout > 0 and args.duration >= 0):
        raise InputError("--period and --timeout must be > 0 and --duration >= 0")
    from ..ros.monitor import run_monitor

    with contextlib.suppress(KeyboardInterrupt):
        run_monitor(node, once=args.once, period=args.period, timeout=args.timeout, duration=args.duration)
    return 0
