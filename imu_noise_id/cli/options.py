"""The options the subcommands share, with one spelling and one meaning each: ``--out DIR`` (:func:`default_out`),
``--topic T`` (older spellings hidden aliases), ``--axis`` (:func:`parse_axes`; default all six), model specs
(:func:`model_spec`) and the options of one analysis for ``analyze``, ``batch``, ``fit`` and ``loop``
(:func:`add_analysis_options`, :func:`analysis_options`)."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from ..core.allan import DEFAULT_CONFIDENCE, DEFAULT_PER_DECADE, KINDS
from ..core.axes import AXES
from ..core.errors import InputError
from ..core.estimation.em.model import FitOptions
from ..core.estimation.gmwm.fit import GmwmOptions
from ..core.estimation.readouts.overbound import DEFAULT_HORIZON_S
from ..core.noise.digital import SensorFilter

if TYPE_CHECKING:
    from ..pipelines.analyze import AnalyzeOptions


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


def sensor_filter_spec(text: str) -> SensorFilter:
    """An argparse ``type`` for ``HZ[:ORDER]``: the sensor's digital low-pass, its −3 dB cutoff [Hz] and, when known,
    its Butterworth order (1–4)."""
    cutoff, sep, order = text.partition(":")
    try:
        return SensorFilter(float(cutoff), int(order) if sep else None)
    except ValueError as exc:
        detail = str(exc) if "sensor filter" in str(exc) else "HZ and ORDER must be numbers"
        raise argparse.ArgumentTypeError(f"{text!r} is not HZ[:ORDER], e.g. 42 or 42:2 ({detail})") from None


sensor_filter_spec.__name__ = "sensor filter"  # argparse names the type in its message


#: The commands that run one analysis (:func:`add_analysis_options`): ``fit`` is its model stage alone, ``loop`` the
#: model stage from a given start and the closed loop, ``batch`` ``analyze`` on many bags.
ANALYSIS_COMMANDS = ("analyze", "batch", "fit", "loop")


def _model_stage_options(p: argparse.ArgumentParser, command: str) -> None:
    """The model stage's options: structure, estimator, the fits' and the GMWM's settings, the sensor's filter."""
    if command == "fit":
        p.add_argument("--model", required=True, type=model_spec("auto"),
                       help="structure, e.g. 'WN+GM+RW+RR' or 'WN+2GM'; 'auto' ranks the default candidates by BIC")
    elif command == "loop":
        p.add_argument("--start", dest="model", default="WN+RW", type=model_spec(),
                       help="starting model structure (default: WN+RW)")
    else:
        p.add_argument(
            "--model", default="auto", type=model_spec("auto", "none"),
            help="EM model fit per axis after the Allan stage: 'auto' (default: BIC over the default candidates), a "
            "structure such as 'WN+GM+RW', or 'none' (Allan only). Writes DIR/model.yaml and DIR/allan_model.png "
            "and puts the model's noise density / random walk into imu.yaml (Allan values kept as *_allan)",
        )
    if command == "fit":
        p.add_argument("--estimator", "--method", dest="estimator", choices=("em", "gmwm"), default="em",
                       help="estimator: maximum likelihood by EM (em, default) or the GMWM on the wavelet variance "
                       "(gmwm)")
    elif command != "loop":
        p.add_argument(
            "--estimator", choices=("auto", "em", "gmwm", "both"), default="auto",
            help="model estimator: 'em' (maximum likelihood), 'gmwm' (wavelet variance; no closed loop), 'both' "
            "(GMWM, then EM from its estimates, compared parameter by parameter) or 'auto' (default: EM, GMWM on "
            "records too long for the EM, with a warning)",
        )
    p.add_argument("--robust", action="store_true",
                   help="GMWM: fit the robust wavelet variance (bounded influence; for records with outliers)")
    p.add_argument(
        "--sensor-filter", type=sensor_filter_spec, default=None, metavar="HZ[:ORDER]",
        help="the sensor's digital low-pass as configured (datasheet and driver): its -3 dB cutoff [Hz] and, when "
        "known, its Butterworth order 1-4, e.g. 42 or 42:2. The model selection then offers WN+DLPF+RW and "
        "WN+DLPF+GM+RW with the filter started there (the cutoff is still estimated; without ORDER the data choose it)")
    p.add_argument("--drift", choices=("em", "ls"), default="em",
                   help="with RR: estimate the ramp jointly (em, default) or remove a least-squares line first (ls)")
    p.add_argument("--starts", type=int, default=FitOptions.n_starts,
                   help=f"Allan-variance initial values tried per fit (default {FitOptions.n_starts})")
    p.add_argument("--target-precision", type=float, default=FitOptions.target_precision,
                   help="relative 95 %% half-width for the recording-length advice (default "
                   f"{FitOptions.target_precision:g})")
    p.add_argument("--efficiency", type=float, default=GmwmOptions.efficiency,
                   help="GMWM --robust: Gaussian efficiency of the robust estimator (default "
                   f"{GmwmOptions.efficiency:g})")
    p.add_argument("--bootstrap", type=int, default=GmwmOptions.bootstrap, metavar="N",
                   help="GMWM: intervals from N parametric-bootstrap records instead of the asymptotic ones")


def _loop_options(p: argparse.ArgumentParser, command: str) -> None:
    """The closed loop's options."""
    if command in ("analyze", "batch"):
        p.add_argument(
            "--no-loop", action="store_true",
            help="skip the closed loop that follows the model fit (residual diagnosis: adds missing GM/RW/RR/QN, "
            "sinusoids, temperature, steps, outliers one at a time while BIC improves; writes a 'loop:' list per "
            "axis into model.yaml and DIR/report.html). It runs by default unless --model none",
        )
    p.add_argument("--temperature-topic", default=None, metavar="T",
                   help="sensor_msgs/Temperature topic for the loop's thermal-bias test (default: the bag's only one)")
    p.add_argument("--alpha", type=float, default=None,
                   help="level of every detector of the closed loop (default: the loop's, 0.01)")
    p.add_argument("--max-steps", type=int, default=None,
                   help="most effects the closed loop adds per axis (default: the loop's; docs/loop.md)")


def add_analysis_options(p: argparse.ArgumentParser, command: str = "analyze") -> None:
    """The options of one analysis, for ``command`` (:data:`ANALYSIS_COMMANDS`): the Allan stage, the model stage,
    the axes, the loop, the overbound and its exports, ``--jobs``; each command shows those of its stages, with one
    spelling, default and help. :func:`analysis_options` reads them back."""
    if command in ("analyze", "batch"):
        p.add_argument("--per-decade", type=int, default=DEFAULT_PER_DECADE,
                       help=f"averaging times per decade of tau (default: {DEFAULT_PER_DECADE})")
        p.add_argument("--confidence", type=float, default=DEFAULT_CONFIDENCE,
                       help=f"confidence level of the intervals (default: {DEFAULT_CONFIDENCE:g})")
    _model_stage_options(p, command)
    add_axis(p, aliases=("--axes",) if command == "loop" else ())
    p.add_argument(
        "--allow-motion", action="store_true",
        help="analyse even if the static check finds motion (its findings become warnings)",
    )
    p.add_argument(
        "--span", type=span_spec, default=None, metavar="START:END",
        help="analyse only the samples from START to END seconds after the first one (START: or :END for the "
        "rest), e.g. the still stretch the static check suggests around a moment of motion")
    if command in ("analyze", "batch"):
        p.add_argument(
            "--horizon", type=float, default=DEFAULT_HORIZON_S, metavar="S",
            help="longest time scale [s] the overbound must cover: the smallest WN+RW whose Allan variance lies "
            "above the data's upper bound and the final model from the sampling period to S (imu.yaml "
            f"'overbound:', report.html; default {DEFAULT_HORIZON_S:g})")
        p.add_argument("--overbound", action="store_true",
                       help="also write the exports of the overbound's values into DIR/exports/overbound/")
    if command != "fit":
        _loop_options(p, command)
    if command != "batch":
        from ..pipelines.analyze import PARALLEL_MIN_SAMPLES

        p.add_argument(
            "--jobs", type=int, default=0, metavar="N",
            help="worker processes for the per-axis model stage and loop, one axis each (default 0: one per "
            f"available core on records of {PARALLEL_MIN_SAMPLES} samples or more; 1: none), and for drawing the "
            "report's figures "
            "(0: one per available core, whatever the record's length). The results are the same; peak memory "
            "adds up over the workers")


def analysis_options(args: argparse.Namespace, *, jobs: int | None = None) -> AnalyzeOptions:
    """The :class:`~imu_noise_id.pipelines.analyze.AnalyzeOptions` of the options :func:`add_analysis_options`
    added for ``args.command`` (``jobs``: instead of ``--jobs``): ``fit`` selects the model stage alone (Allan stage
    for the starts, no loop, no final model), ``loop`` the model stage from ``--start`` by the EM and the loop.
    ``--overbound`` is not among them: it says which files are written.

    Raises
    ------
    InputError
        A value out of range (``--horizon``, ``--confidence``, ``--per-decade``, ``--jobs``, ``--starts``,
        ``--bootstrap``, ``--alpha``, ``--max-steps``, ``--axis``).
    """
    from ..pipelines.analyze import AnalyzeOptions, ModelStage

    if args.starts < 1 or args.bootstrap < 0:
        raise InputError(f"--starts must be >= 1 and --bootstrap >= 0, got {args.starts}, {args.bootstrap}")
    command = getattr(args, "command", "analyze")
    fit = command == "fit"
    gmwm = GmwmOptions(robust=args.robust, efficiency=args.efficiency, n_starts=args.starts, bootstrap=args.bootstrap,
                       target_precision=args.target_precision)
    stage = ModelStage(args.model, FitOptions(n_starts=args.starts, target_precision=args.target_precision),
                       args.drift, estimator=getattr(args, "estimator", "em"), gmwm=gmwm,
                       sensor_filter=args.sensor_filter)
    return AnalyzeOptions(kinds=("allan",) if fit else KINDS,
                          per_decade=getattr(args, "per_decade", DEFAULT_PER_DECADE),
                          confidence=getattr(args, "confidence", DEFAULT_CONFIDENCE), allow_motion=args.allow_motion,
                          models=stage, axes=tuple(parse_axes(args.axis)),
                          loop=not (fit or getattr(args, "no_loop", False)), loop_alpha=getattr(args, "alpha", None),
                          loop_max_steps=getattr(args, "max_steps", None), finals=not fit,
                          horizon_s=getattr(args, "horizon", DEFAULT_HORIZON_S),
                          jobs=args.jobs if jobs is None else jobs, span=args.span)
