"""``imu-noise-id fit``: maximum-likelihood fit (constrained EM + quasi-Newton) of a chosen error model."""

from __future__ import annotations

import argparse
from pathlib import Path

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
    p.add_argument("--drift", choices=("em", "ls"), default="em",
                   help="with RR: estimate the ramp jointly (em, default) or remove a least-squares line first (ls)")
    p.add_argument("--starts", type=int, default=3, help="Allan-variance initial values tried (default 3)")
    p.add_argument("--target-precision", type=float, default=0.10,
                   help="relative 95 %% half-width for the recording-length advice (default 0.10)")
    p.set_defaults(run=run)


def load_series(path: str, topic: str | None):
    """ImuSeries from an .npz (t, gyro, accel) or a bag (imu_noise_id.bag.reader.read_imu)."""
    import numpy as np

    from ..core.axes import ImuSeries
    from ..core.errors import InputError

    p = Path(path)
    if not p.exists():
        raise InputError(f"{path}: no such file or directory")
    if p.suffix == ".npz":
        with np.load(p) as data:
            missing = [k for k in ("gyro", "accel") if k not in data]
            if missing:
                raise InputError(f"{path}: .npz lacks array(s) {', '.join(missing)} (need t, gyro, accel)")
            gyro, accel = np.asarray(data["gyro"], float), np.asarray(data["accel"], float)
            if "t" in data:
                t = np.asarray(data["t"], float)
            elif "fs_hz" in data:
                t = np.arange(gyro.shape[0]) / float(data["fs_hz"])
            else:
                raise InputError(f"{path}: .npz needs t [s] or fs_hz")
        return ImuSeries(t=t, gyro=gyro, accel=accel, topic=str(p))
    try:
        from ..bag.reader import read_imu
    except ImportError:
        raise InputError(f"{path}: reading bags needs imu_noise_id.bag.reader, missing in this build; "
                         "pass an .npz with t, gyro, accel") from None
    return read_imu(path, topic=topic)


def sampling_period(t) -> float:
    """Median sample spacing [s]; InputError if the time stamps are not increasing."""
    import numpy as np

    from ..core.errors import InputError

    d = np.diff(np.asarray(t, float))
    if d.size == 0 or not np.all(np.isfinite(d)) or np.median(d) <= 0:
        raise InputError("time stamps must be finite and increasing (need at least 2 samples)")
    return float(np.median(d))


def fit_axes(series, model: str, axes: list[str], **kwargs):
    """Fit ``model`` (or select with ``'auto'``) on each axis of an ImuSeries; returns (fits, selections)."""
    from ..core.errors import InputError
    from ..core.estimation.fit import fit_model, select_model

    fits, selections = {}, {}
    dt = sampling_period(series.t)
    for axis in axes:
        y = series.axis(axis)
        try:
            if model == "auto":
                sel = select_model(y, dt, **kwargs)
                fits[axis], selections[axis] = sel.best, sel
            else:
                fits[axis] = fit_model(y, dt, model, **kwargs)
        except InputError as exc:
            raise InputError(f"{axis}: {exc}") from None
        f = fits[axis]
        print(f"{axis}: {f.model}  loglik {f.loglik:.6g}  BIC {f.bic:.6g}  "
              + "  ".join(str(c) for c in f.components), flush=True)
        # The outputs need the fitted models, not the records: drop them so memory does not grow per axis.
        fits[axis] = f.without_data()
        if axis in selections:
            selections[axis] = selections[axis].without_data()
    return fits, selections


def run(args: argparse.Namespace) -> int:
    from ..core.axes import AXES
    from ..core.errors import InputError
    from ..report.model_yaml import write_model_yaml

    axes = args.axis or list(AXES)
    bad = [a for a in axes if a not in AXES]
    if bad:
        raise InputError(f"unknown axis {', '.join(bad)}: use {', '.join(AXES)}")
    series = load_series(args.bag, args.topic)
    kwargs = {"n_starts": args.starts, "target_precision": args.target_precision, "drift": args.drift}
    fits, selections = fit_axes(series, args.model, axes, **kwargs)
    out = write_model_yaml(Path(args.out) / "model.yaml", fits, selections,
                           meta={"source": str(args.bag), "topic": series.topic, "command": "fit",
                                 "model": args.model})
    print(f"wrote {out}")
    return 0
