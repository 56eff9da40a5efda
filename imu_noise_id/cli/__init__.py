"""``imu-noise-id`` command line: one module per subcommand, each with ``register(subparsers)``.

Exit codes: 0 success, 2 usage or input error (one message on stderr, no traceback), 1 internal error.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from ..core.errors import InputError

#: Subcommand modules of this package, in the order ``--help`` lists them.
COMMANDS: tuple[str, ...] = (
    "analyze", "batch", "fit", "loop", "simulate", "inspect", "identify", "criteria", "cmkf", "play", "monitor",
)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="imu-noise-id",
        description="Identify an IMU's stochastic errors: Allan variance, EM model fits, online estimation.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"{__name__}.{name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``imu-noise-id`` (and ``python -m imu_noise_id``)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except InputError as exc:
        print(f"imu-noise-id {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"imu-noise-id {args.command}: interrupted", file=sys.stderr)
        return 130
