"""``imu-noise-id fit``: maximum-likelihood fit (constrained EM + quasi-Newton) of a chosen error model."""

from __future__ import annotations

import argparse
from pathlib import Path

from . import add_rate_option, print_notes, results_folder

DESCRIPTION = """\
Fit a stochastic error model to the static IMU record in BAG by maximum likelihood (constrained EM of
Stebler et al. 2011, finished by quasi-Newton on the exact Kalman-filter likelihood) and write DIR/model.yaml:
per axis the fitted components in continuous-time units (noise_density [u/sqrt(Hz)], random_walk
[u/s/sqrt(Hz)], GM tau [s] and sigma [u], RR slope [u/s], QN Q [u*s]) with their per-sample values, standard
errors and 95 % intervals, the bias, log-likelihood, AIC, BIC and how long to record for +-10 % precision.

BAG is a recording (ROS 1 .bag, rosbag2 sqlite3 or mcap; imu_noise_id.bag.reader) or an .npz with t [s], gyro
[rad/s] (N,3) and accel [m/s^2] (N,3). The record must be static (sensor at rest)."""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("fit", help="fit an error model (EM / maximum likelihood) and write model.yaml",
                              description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("bag", metavar="BAG", help="bag file / rosbag2 directory, or .npz with t, gyro, accel")
    p.add_argument("--model", required=True,
                   help="structure, e.g. 'WN+GM+RW+RR' or 'WN+2GM'; 'auto' ranks the default candidates by BIC")
    p.add_argument("--axis", action="append", default=None,
                   help="axis to fit (gyro_x … accel_z; repeatable); default: all six")
    p.add_argument("--topic", default=None, help="IMU topic in the bag (default: the only sensor_msgs/Imu topic)")
    p.add_argument("--out", default=".", metavar="DIR", help="output directory (default: current directory)")
    add_rate_option(p)
    p.add_argument("--drift", choices=("em", "ls"), default="em",
                   help="with RR: estimate the ramp jointly (em, default) or remove a least-squares line first (ls)")
    p.add_argument("--starts", type=int, default=3, help="Allan-variance initial values tried (default 3)")
    p.add_argument("--target-precision", type=float, default=0.10,
                   help="relative 95 %% half-width for the recording-length advice (default 0.10)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..bag.reader import read_static
    from ..core.axes import AXES
    from ..core.errors import InputError
    from ..core.estimation.model import FitOptions
    from ..pipelines.analyze.models import ModelStage, fit_axes
    from ..report.console import fit_line
    from ..report.model_yaml import write_model_yaml

    axes = args.axis or list(AXES)
    bad = [a for a in axes if a not in AXES]
    if bad:
        raise InputError(f"unknown axis {', '.join(bad)}: use {', '.join(AXES)}")
    stage = ModelStage(args.model, FitOptions(n_starts=args.starts, target_precision=args.target_precision),
                       args.drift)
    recording = read_static(args.bag, topic=args.topic, rate_hz=args.rate)
    series = recording.imu
    print_notes(recording.notes)
    models = fit_axes(series, axes, stage, series.dt,
                      on_fit=lambda axis, fit: print(fit_line(axis, fit), flush=True))
    meta = {"source": str(args.bag), "topic": series.topic, "command": "fit", "model": args.model,
            "notes": recording.notes}
    folder = results_folder(args, str(args.bag), series.topic)
    with folder as staging:
        write_model_yaml(staging / "model.yaml", models, meta=meta)
    folder.report()
    print(f"wrote {Path(args.out) / 'model.yaml'}")
    return 0
