"""``imu-noise-id fit``: maximum-likelihood fit (constrained EM + quasi-Newton) of a chosen error model."""

from __future__ import annotations

import argparse
from pathlib import Path

from . import add_rate_option, print_notes, results_folder
from .options import add_axis, add_out, add_topic, model_spec

DESCRIPTION = """\
Fit a stochastic error model to the static IMU record in BAG by maximum likelihood (constrained EM of
Stebler et al. 2011, finished by quasi-Newton on the exact Kalman-filter likelihood) and write DIR/model.yaml:
per axis the fitted components in continuous-time units (noise_density [u/sqrt(Hz)], random_walk
[u/s/sqrt(Hz)], GM tau [s] and sigma [u], RR slope [u/s], QN Q [u*s]) with their per-sample values, standard
errors and 95 % intervals, the bias, log-likelihood, AIC, BIC and how long to record for +-10 % precision.
With --method gmwm the model is fitted to the Haar wavelet variance instead (Guerrier et al. 2013: fast on long
records, --robust for contaminated ones; its J-test and the wavelet variance are written under 'moments:').

BAG is a recording (ROS 1 .bag, rosbag2 sqlite3 or mcap; imu_noise_id.bag.reader) or an .npz with t [s], gyro
[rad/s] (N,3) and accel [m/s^2] (N,3). The record must be static (sensor at rest)."""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("fit", help="fit an error model (EM / maximum likelihood) and write model.yaml",
                              description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("bag", metavar="BAG", help="bag file / rosbag2 directory, or .npz with t, gyro, accel")
    p.add_argument("--model", required=True, type=model_spec("auto"),
                   help="structure, e.g. 'WN+GM+RW+RR' or 'WN+2GM'; 'auto' ranks the default candidates by BIC")
    add_axis(p)
    add_topic(p)
    add_out(p, "fit")
    add_rate_option(p)
    p.add_argument("--drift", choices=("em", "ls"), default="em",
                   help="with RR: estimate the ramp jointly (em, default) or remove a least-squares line first (ls)")
    p.add_argument("--method", choices=("em", "gmwm"), default="em",
                   help="estimator: maximum likelihood by EM (em, default) or the GMWM on the wavelet variance (gmwm)")
    p.add_argument("--robust", action="store_true",
                   help="gmwm: fit the robust wavelet variance (bounded influence; for records with outliers)")
    p.add_argument("--efficiency", type=float, default=0.6,
                   help="gmwm --robust: Gaussian efficiency of the robust estimator (default 0.6)")
    p.add_argument("--bootstrap", type=int, default=0, metavar="N",
                   help="gmwm: intervals from N parametric-bootstrap records instead of the asymptotic ones")
    p.add_argument("--starts", type=int, default=3, help="Allan-variance initial values tried (default 3)")
    p.add_argument("--target-precision", type=float, default=0.10,
                   help="relative 95 %% half-width for the recording-length advice (default 0.10)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Check the options, read the bag, fit each axis (progress on stderr), write model.yaml, print the advice."""
    from ..bag.reader import read_static
    from ..core.errors import InputError
    from ..core.estimation.em.model import FitOptions
    from ..core.estimation.gmwm.fit import GmwmOptions
    from ..pipelines.analyze.models import ModelStage, fit_axes
    from ..report.console import fit_line, record_length_lines
    from ..report.model_yaml import write_model_yaml
    from .options import parse_axes
    from .progress import TextProgress

    axes = parse_axes(args.axis)
    if args.starts < 1 or args.bootstrap < 0:
        raise InputError(f"--starts must be >= 1 and --bootstrap >= 0, got {args.starts}, {args.bootstrap}")
    gmwm = GmwmOptions(robust=args.robust, efficiency=args.efficiency, n_starts=args.starts, bootstrap=args.bootstrap,
                       target_precision=args.target_precision)
    stage = ModelStage(args.model, FitOptions(n_starts=args.starts, target_precision=args.target_precision),
                       args.drift, estimator=args.method, gmwm=gmwm)
    with TextProgress(f"reading {args.bag}") as progress:
        recording = read_static(args.bag, topic=args.topic, progress=progress, rate_hz=args.rate)
    series = recording.imu
    print_notes(recording.notes)
    with TextProgress(f"fitting {args.model}", unit="axes") as progress:
        progress(0, len(axes))
        fitted: list[str] = []

        def on_fit(axis: str, fit) -> None:
            fitted.append(axis)
            progress.echo(fit_line(axis, fit))
            if fit.budget_stop is not None:
                progress.echo(f"{axis}: {fit.budget_stop_text()}")
            if fit.beyond_budget:
                progress.echo(f"{axis}: profile budget spent; other intervals for "
                              + ", ".join(f"{lab} ({how})" for lab, how in fit.beyond_budget.items()))
            progress(len(fitted), len(axes))

        models = fit_axes(series, axes, stage, series.dt, on_fit=on_fit)
    meta = {"source": str(args.bag), "topic": series.topic, "command": "fit", "model": args.model,
            "method": args.method, "notes": recording.notes}
    folder = results_folder(args, str(args.bag), series.topic)
    with folder as staging:
        write_model_yaml(staging / "model.yaml", models, meta=meta)
    folder.report()
    print(f"wrote {Path(args.out) / 'model.yaml'}")
    for line in record_length_lines({axis: m.fit for axis, m in models.items()}):
        print(line)
    return 0
