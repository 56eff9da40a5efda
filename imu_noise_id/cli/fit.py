"""``imu-noise-id fit``: ``analyze``'s model stage alone (:func:`~.analyze.run_analysis` with the options of
:func:`~.options.analysis_options` for ``fit``): the chosen model fitted by maximum likelihood on the chosen axes,
``model.yaml`` written."""

from __future__ import annotations

import argparse
from pathlib import Path

from . import add_rate_option, print_notes, results_folder
from .options import add_analysis_options, add_out, add_topic

DESCRIPTION = """\
Fit a stochastic error model to the static IMU record in BAG by maximum likelihood (constrained EM of
Stebler et al. 2011, finished by quasi-Newton on the exact Kalman-filter likelihood; starting values fitted to the
record's Allan variance) and write DIR/model.yaml: per axis the fitted components in continuous-time units
(noise_density [u/sqrt(Hz)], random_walk [u/s/sqrt(Hz)], GM tau [s] and sigma [u], RR slope [u/s], QN Q [u*s]) with
their per-sample values, standard errors and 95 % intervals, the bias, log-likelihood, AIC, BIC and how long to
record for +-10 % precision. This is analyze's model stage alone, with the same options. With --estimator gmwm the
model is fitted to the Haar wavelet variance instead (Guerrier et al. 2013: fast on long records, --robust for
contaminated ones; its J-test and the wavelet variance are written under 'moments:').

BAG is a recording (ROS 1 .bag, rosbag2 sqlite3 or mcap; imu_noise_id.bag.reader) or an .npz with t [s], gyro
[rad/s] (N,3) and accel [m/s^2] (N,3). The record must be static (sensor at rest)."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``fit`` parser."""
    p = subparsers.add_parser("fit", help="fit an error model (EM / maximum likelihood) and write model.yaml",
                              description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("bag", type=Path, metavar="BAG", help="bag file / rosbag2 directory, or .npz with t, gyro, accel")
    add_topic(p)
    add_out(p, "fit")
    add_rate_option(p)
    add_analysis_options(p, "fit")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Fit each axis (progress on stderr), write model.yaml, print the advice."""
    from ..report.console import fit_line, parameter_lines, record_length_lines
    from ..report.model_yaml import write_model_yaml
    from .analyze import run_analysis
    from .options import analysis_options

    def on_axis(axis: str, fit, loop, bar) -> None:
        bar.echo(fit_line(axis, fit))
        for line in parameter_lines(axis, fit):
            bar.echo(line)
        if fit.budget_stop is not None:
            bar.echo(f"{axis}: {fit.budget_stop_text()}")
        if fit.beyond_budget:
            bar.echo(f"{axis}: profile budget spent; other intervals for "
                     + ", ".join(f"{lab} ({how})" for lab, how in fit.beyond_budget.items()))

    options = analysis_options(args)
    recording, result = run_analysis(args, options, on_axis)
    print_notes(recording.notes)
    meta = {"source": str(args.bag), "topic": recording.imu.topic, "command": "fit", "model": args.model,
            "method": options.models.estimator, "notes": recording.notes}
    folder = results_folder(args, str(args.bag), recording.imu.topic)
    with folder as staging:
        write_model_yaml(staging / "model.yaml", result.models, meta=meta)
    folder.report()
    print(f"wrote {Path(args.out) / 'model.yaml'}")
    for line in record_length_lines(result.fits):
        print(line)
    return 0
