"""``imu-noise-id`` command line: one module per subcommand, each with ``register(subparsers)``.

Exit codes: 0 success, 2 usage or input error (one message on stderr, no traceback), 1 internal error. Shared
options: :mod:`.options`.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from ..core.errors import InputError
from . import blas_threads  # noqa: F401  (before .options, which loads numpy)
from .options import resolve_out

if TYPE_CHECKING:
    from ..report.results_folder import ResultsFolder

#: Subcommand modules of this package, in the order ``--help`` lists them.
COMMANDS: tuple[str, ...] = (
    "analyze", "batch", "export", "fit", "loop", "simulate", "inspect", "compare", "identify", "criteria", "cmkf",
    "play", "monitor",
)


#: Commands whose ``--out`` is a directory they write into (``simulate``'s is the bag it writes).
DIRECTORY_OUTPUT = frozenset({"analyze", "batch", "cmkf", "criteria", "fit", "identify", "loop"})


def check_output_dir(path: Path) -> None:
    """Create ``--out`` now, before any work, or say why it cannot be used.

    Raises
    ------
    InputError
        ``path`` is a file, cannot be created, or is not writable.
    """
    if path.exists() and not path.is_dir():
        raise InputError(f"--out {str(path)!r} is a file, not a directory: give a directory to write the results into")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"--out {str(path)!r} cannot be created ({exc.strerror or exc}): choose another "
                         "directory") from None
    if not os.access(path, os.W_OK | os.X_OK):
        raise InputError(f"--out {str(path)!r} is not writable: choose another directory")


def print_notes(notes: list[str]) -> None:
    """The reader's repair and timing notes on stderr, one ``note:`` line each."""
    for note in notes:
        print(f"note: {note}", file=sys.stderr)


def results_folder(args: argparse.Namespace, source: str | None, topic: str | None) -> ResultsFolder:
    """The staging and manifest of ``--out`` for this run (:mod:`imu_noise_id.report.results_folder`)."""
    from ..report.results_folder import ResultsFolder, RunRecord, options_of

    record = RunRecord(command=args.command, argv=list(args.argv), source=source, topic=topic,
                       options=options_of(args), started=args.started)
    return ResultsFolder(Path(args.out), record)


def add_rate_option(parser: argparse.ArgumentParser) -> None:
    """``--rate HZ``: the IMU's sample rate when its stamps cannot give it (see :mod:`imu_noise_id.core.timing`)."""
    parser.add_argument(
        "--rate", type=float, default=None, metavar="HZ",
        help="the IMU's sample rate [Hz], e.g. the driver's configured output rate: use it instead of the rate "
             "estimated from the stamps (needed when they are bursty and the bag's receive times disagree)",
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
    from ..report.results_folder import now

    parser = build_parser()
    args = parser.parse_args(argv)
    made: Path | None = None  # an output folder this run created, removed again if the run fails and left it empty
    args.argv = list(sys.argv[1:] if argv is None else argv)
    args.started = now()
    try:
        if args.command in DIRECTORY_OUTPUT:
            out = resolve_out(args)
            made = None if out.exists() else out
            check_output_dir(out)
        return int(args.run(args) or 0)
    except InputError as exc:
        print(f"imu-noise-id {args.command}: error: {exc}", file=sys.stderr)
        _remove_if_empty(made)
        return 2
    except BrokenPipeError:  # e.g. `imu-noise-id simulate … | head`: the reader left, the work is done
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as exc:  # a file named on the command line cannot be used (name too long, permissions, disk full)
        what = f" {str(exc.filename)[:120]!r}" if exc.filename else ""
        print(f"imu-noise-id {args.command}: error: cannot use{what}: {exc.strerror or exc}", file=sys.stderr)
        _remove_if_empty(made)
        return 2
    except KeyboardInterrupt:
        print(f"imu-noise-id {args.command}: interrupted", file=sys.stderr)
        _remove_if_empty(made)
        return 130


def _remove_if_empty(path: Path | None) -> None:
    if path is not None and path.is_dir() and not any(path.iterdir()):
        path.rmdir()
