"""``imu-noise-id export DIR_OR_IMU_YAML --format …``: the filters' exports (:mod:`imu_noise_id.report.exports`) from
an analysis's ``imu.yaml`` alone (never the bag), parsed once into its numbers."""

from __future__ import annotations

import argparse
from pathlib import Path


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``export`` parser."""
    from ..report.exports import FORMATS

    p = subparsers.add_parser(
        "export", help="write the noise figures for Kalibr, OpenVINS, VINS, ORB-SLAM3, GTSAM, PX4 EKF2 or a REP-145 "
                       "driver from an imu.yaml",
        description="Convert an analysis's imu.yaml (its final models' numbers) into other filters' formats, each in "
                    "its own units and continuous/discrete convention, stated with the formula in the file's header "
                    "(docs/analysis.md#exports). --overbound writes the overbound's values instead (imu.yaml "
                    "'overbound:': the smallest WN+RW covering the data's upper 95 % Allan bound over the filter's "
                    "tau range) into the output folder's overbound/.")
    p.add_argument("source", type=Path, metavar="DIR", help="an analyze output folder (DIR) or its imu.yaml")
    p.add_argument("--format", nargs="+", action="extend", default=None, metavar="FORMAT[,FORMAT…]",
                   help=f"one or more of {', '.join(FORMATS)}, or all; repeatable, space- or comma-separated like "
                        "--axis (default: all)")
    p.add_argument("--overbound", action="store_true",
                   help="export the overbound of imu.yaml (not the fitted values), into the output folder's overbound/")
    p.add_argument("--out", type=Path, metavar="DIR", help="output directory (default: DIR/exports of the analysis)")
    p.set_defaults(run=run)


def parse_formats(values: list[str] | None) -> tuple[str, ...]:
    """The formats of ``--format`` values (comma lists, ``all`` for every one), in order, without repeats.

    Raises
    ------
    InputError
        An unknown format name (before any file is read).
    """
    from ..core.errors import InputError
    from ..report.exports import FORMATS

    names = [v.strip() for value in values or ["all"] for v in value.split(",") if v.strip()]
    unknown = [n for n in names if n not in (*FORMATS, "all")]
    if unknown:
        raise InputError(f"--format {unknown[0]!r}: unknown format; use {', '.join(FORMATS)} or all, repeated or "
                         "comma-separated")
    if not names or "all" in names:
        return tuple(FORMATS)
    return tuple(dict.fromkeys(names))


def run(args: argparse.Namespace) -> int:
    """Read imu.yaml, write the exports."""
    import yaml

    from ..core.errors import InputError
    from ..report.exports import write_exports
    from ..report.imu_yaml import parse_imu_yaml
    from ..report.results_folder import RunRecord, now, options_of, stamp

    formats = parse_formats(args.format)
    path = args.source / "imu.yaml" if args.source.is_dir() else args.source
    try:
        doc = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError, UnicodeDecodeError) as exc:
        raise InputError(f"{str(path)!r}: cannot read it as an imu.yaml ({exc}); give an analyze output folder") \
            from None
    if not isinstance(doc, dict):
        raise InputError(f"{str(path)!r} is not an imu.yaml written by imu-noise-id analyze")
    numbers = parse_imu_yaml(doc, str(path))
    record = RunRecord(command="export", argv=list(args.argv), source=str(path), topic=numbers.topic,
                       options=options_of(args), started=args.started, finished=now(), completed=True)
    for p in write_exports(numbers, args.out or path.parent / "exports", formats, overbound=args.overbound):
        stamp(p, p.name, record.as_dict())
        print(p)
    return 0
