"""The options the subcommands share, with one spelling and one meaning each.

- ``--out DIR``: defaults to ``<BAG stem>_<command>`` in the current directory (``imu_noise_id_<command>`` without
  one bag: ``criteria``, ``batch``) (:func:`default_out`).
- ``--topic T``: the sensor_msgs/Imu topic (older spellings stay as hidden aliases).
- ``--axis AXIS[,AXIS…]``: repeatable and/or a comma list; default all six axes (:func:`parse_axes`).
- ``--model`` / ``--start``: model specs checked while the command line is parsed (:func:`model_spec`).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from pathlib import Path

from ..core.axes import AXES
from ..core.errors import InputError


def default_out(command: str, bag: str | Path | None) -> Path:
    """``<bag stem>_<command>`` (``imu_noise_id_<command>`` without a bag), in the current directory."""
    if bag is None:
        return Path(f"imu_noise_id_{command}")
    name = Path(str(bag).rstrip("/")).name
    stem = Path(name).stem if Path(name).suffix in (".bag", ".mcap", ".db3", ".npz") else name
    return Path(f"{stem or 'imu'}_{command}")


def add_out(p: argparse.ArgumentParser, command: str, *, per_bag: bool = True) -> None:
    """``--out DIR`` with the common default (resolved by :func:`resolve_out`)."""
    default = f"<BAG stem>_{command}" if per_bag else f"imu_noise_id_{command}"
    p.add_argument("--out", type=Path, default=None, metavar="DIR",
                   help=f"output directory (default: {default} in the current directory)")


def resolve_out(args: argparse.Namespace) -> Path:
    """``args.out``, or the default of :func:`default_out` for ``args.command`` (set into ``args``)."""
    if args.out is None:
        args.out = default_out(args.command, getattr(args, "bag", None))
    return Path(args.out)


def add_topic(p: argparse.ArgumentParser, help_text: str = "sensor_msgs/Imu topic (needed only when the bag has "
              "several)", *, aliases: tuple[str, ...] = (), several: bool = False, **kwargs) -> None:
    """``--topic`` (``several``: one or more) with ``aliases``: older spellings kept working, hidden from --help."""
    extra = {"nargs": "+"} if several else {}
    p.add_argument("--topic", dest="topic", metavar="T", help=help_text, **extra, **kwargs)
    for alias in aliases:
        p.add_argument(alias, dest="topic", help=argparse.SUPPRESS, **extra)


def add_axis(p: argparse.ArgumentParser, *, aliases: tuple[str, ...] = ()) -> None:
    """``--axis AXIS[,AXIS…]``, repeatable; ``aliases`` kept working, hidden."""
    p.add_argument("--axis", dest="axis", action="append", default=None, metavar="AXIS[,AXIS…]",
                   help=f"axes to process, repeatable and/or comma-separated ({', '.join(AXES)}, or gyro / accel "
                   "for a sensor's three); default: all six")
    for alias in aliases:
        p.add_argument(alias, dest="axis", action="append", help=argparse.SUPPRESS)


def parse_axes(values: list[str] | None) -> list[str]:
    """The axes of ``--axis`` values (comma lists, ``gyro``/``accel`` for three), in order, without repeats.

    Raises
    ------
    InputError
        An unknown axis name (before any bag is read).
    """
    if not values:
        return list(AXES)
    out: list[str] = []
    for value in values:
        for name in (v.strip() for v in value.split(",")):
            if not name:
                continue
            group = [a for a in AXES if a.startswith(f"{name}_")] if name in ("gyro", "accel") else [name]
            if group[0] not in AXES:
                raise InputError(f"--axis {name!r}: unknown axis; use {', '.join(AXES)} (or gyro, accel), "
                                 "repeated or comma-separated")
            out += [a for a in group if a not in out]
    if not out:
        raise InputError("--axis: no axis given; use e.g. --axis gyro_z,accel_x")
    return out


def model_spec(*keywords: str) -> Callable[[str], str]:
    """An argparse ``type`` accepting ``keywords`` (e.g. ``auto``) or a model structure such as ``WN+GM+RW``."""

    def check(text: str) -> str:
        if text in keywords:
            return text
        from ..core.noise.modelspec import parse_structure

        try:
            parse_structure(text)
        except InputError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        return text

    check.__name__ = "model spec"  # argparse names the type in its message
    return check


def span_spec(text: str) -> tuple[float, float]:
    """An argparse ``type`` for ``START:END``, seconds from the first sample (``START:`` to the end, ``:END`` from the
    start)."""
    start, sep, end = text.partition(":")
    try:
        if not sep:
            raise ValueError
        span = (float(start) if start.strip() else 0.0, float(end) if end.strip() else math.inf)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not START:END in seconds from the first sample, e.g. "
                                         "0:35.3 or 120:") from None
    if not 0.0 <= span[0] < span[1]:
        raise argparse.ArgumentTypeError(f"{text!r}: START must be ≥ 0 and below END")
    return span


span_spec.__name__ = "span"  # argparse names the type in its message
