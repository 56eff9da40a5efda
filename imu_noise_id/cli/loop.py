"""``imu-noise-id loop BAG``: the closed loop (fit → residual diagnosis → add the missing effect → refit) on
chosen axes of a static recording; writes ``DIR/model.yaml`` (``loop:`` per axis) and ``DIR/report.html``."""

from __future__ import annotations

import argparse
from pathlib import Path

DEFAULT_OUT = "imu_noise_id_results"
#: Automatic decimation keeps at most this many samples per axis (a few seconds to a minute per fit).
MAX_SAMPLES = 200_000


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``loop`` parser."""
    p = subparsers.add_parser(
        "loop",
        help="closed loop: find the effects the noise model misses (GM, RW, RR, QN, SIN, TEMP, STEP, OUTLIERS)",
        description=(
            "Fit a starting noise model to each chosen axis of a static bag, test its residuals (standardised "
            "innovations, Allan variance against the model's) for missing effects, add the most significant one "
            "(state-space component, deterministic regressor or outlier removal), refit, and keep it only if the "
            "BIC improves and its evidence is gone; repeat until the residuals pass or nothing improves. Writes "
            "DIR/model.yaml (a 'loop:' list per axis with the errors before and after each step) and "
            "DIR/report.html (self-contained, with before/after Allan plots and residual ACF/PSD). A "
            "sensor_msgs/Temperature topic in the bag enables the thermal-bias test."
        ),
    )
    p.add_argument("bag", type=Path, help="bag file or rosbag2 directory")
    p.add_argument("--topic", help="sensor_msgs/Imu topic (needed only when the bag has several)")
    p.add_argument("--temperature-topic", help="sensor_msgs/Temperature topic (default: the bag's only one)")
    p.add_argument("--start", default="WN+RW", help="starting model structure (default: WN+RW)")
    p.add_argument("--axes", default="gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z",
                   help="comma-separated axes (default: all six)")
    p.add_argument("--decimate", type=int, default=0,
                   help="block-average N samples first (default 0 = automatic: the smallest N leaving at most "
                        f"{MAX_SAMPLES} samples per axis; 1 = none)")
    p.add_argument("--max-steps", type=int, default=6, help="most effects added per axis (default: 6)")
    p.add_argument("--alpha", type=float, default=0.01, help="level of every detector (default: 0.01)")
    p.add_argument("--out", type=Path, default=Path(DEFAULT_OUT), help=f"output directory (default: {DEFAULT_OUT})")
    p.set_defaults(run=run)


def summary(results: dict) -> str:
    """One line per step: axis, step, model, errors."""
    lines = [f"{'axis':8s} {'step':>4s} {'model':28s} {'loglik':>12s} {'BIC':>12s} {'AVmis':>6s} {'LB p':>8s} "
             f"{'peak':>6s}"]
    for axis, r in results.items():
        for s in r.steps:
            e = s.errors
            lines.append(f"{axis:8s} {s.index:4d} {s.model:28s} {e.loglik:12.1f} {e.bic:12.1f} {e.av_misfit:6.3f} "
                         f"{e.ljung_box_p:8.2g} {e.peak_ratio:6.1f}")
        lines.append(f"{axis:8s}      -> {r.verdict}")
    return "\n".join(lines)


def loop_stage(imu, temperature, out_dir: Path, *, start: str | dict[str, str] = "WN+RW",
               axes: tuple[str, ...] | None = None, decimate: int = 0, max_steps: int = 6, alpha: float = 0.01,
               title: str = "closed loop") -> tuple[dict, dict[str, Path], int]:
    """Run the loop on an IMU recording and write ``out_dir/model.yaml`` (``loop:``) and ``out_dir/report.html``.

    This is the stage ``analyze`` calls (unless ``--no-loop``): ``start`` is the starting structure for every
    axis or per axis (e.g. the models the EM stage selected); ``decimate = 0`` picks the smallest block-average
    factor leaving at most :data:`MAX_SAMPLES` samples per axis. Returns (results by axis, written paths,
    decimation factor used).
    """
    from ..core.axes import AXES
    from ..pipelines.closed_loop import run_closed_loop_imu
    from ..report.html import write_loop_report
    from ..report.loop_yaml import add_loop_to_model_yaml

    factor = decimate if decimate >= 1 else max(1, -(-len(imu) // MAX_SAMPLES))
    results = run_closed_loop_imu(imu, start, temperature=temperature, axes=axes or AXES, decimate=factor,
                                  max_steps=max_steps, alpha=alpha)
    note = f" (block-averaged by {factor})" if factor > 1 else ""
    paths = {"model": add_loop_to_model_yaml(out_dir / "model.yaml", results),
             "report": write_loop_report(out_dir / "report.html", results, title=title + note)}
    return results, paths, factor


def run(args: argparse.Namespace) -> int:
    """Read the bag, run the loop, write model.yaml and report.html."""
    from ..bag.reader import read_imu, read_temperature
    from ..core.axes import AXES
    from ..core.errors import InputError
    from ..core.noise.modelspec import parse_structure

    axes = tuple(a.strip() for a in args.axes.split(",") if a.strip())
    unknown = [a for a in axes if a not in AXES]
    if unknown or not axes:
        raise InputError(f"--axes: unknown axis {', '.join(unknown) or '(none)'}; use {', '.join(AXES)}")
    parse_structure(args.start)
    if args.decimate < 0 or args.max_steps < 0 or not 0 < args.alpha < 1:
        raise InputError("--decimate must be >= 0, --max-steps >= 0 and --alpha in (0, 1)")
    imu = read_imu(args.bag, topic=args.topic)
    temperature = read_temperature(args.bag, topic=args.temperature_topic)
    results, paths, factor = loop_stage(imu, temperature, args.out, start=args.start, axes=axes,
                                        decimate=args.decimate, max_steps=args.max_steps, alpha=args.alpha,
                                        title=f"closed loop: {args.bag.name}")
    print(summary(results), flush=True)
    note = f" (block-averaged by {factor})" if factor > 1 else ""
    print(f"results{note} in {args.out}/: " + ", ".join(p.name for p in paths.values()))
    return 0
