"""``imu-noise-id identify BAG``: recursive Bayesian hypothesis probabilities per axis (paper 002)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from ..core.axes import AXES, UNITS, ImuSeries
from ..core.errors import InputError

#: Rows per axis kept in the probability CSV and plot.
MAX_ROWS = 2000


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "identify",
        help="which error model fits each axis: Bayesian hypothesis probabilities vs time",
        description=(
            "Run the recursive Bayesian hypothesis bank (Stepanov & Motorin 2019) on a static IMU recording: "
            "for every axis, the posterior probability of each error-model hypothesis (default: WN+RW vs "
            "WN+GM, each with a constant bias) as data accumulate, the decision once one reaches gamma, and "
            "the parameter estimates with their relative standard deviations. Writes DIR/hypotheses.yaml, "
            "DIR/hypotheses_probabilities.csv and DIR/hypotheses_probabilities.png."
        ),
    )
    p.add_argument("bag", help="rosbag2 directory, .mcap/.db3 file or ROS 1 .bag with a static IMU recording")
    p.add_argument("--hypotheses", metavar="FILE", default=None,
                   help="hypothesis set YAML (default: config/hypotheses_default.yaml)")
    p.add_argument("--axis", nargs="+", default=list(AXES), choices=AXES, metavar="AXIS",
                   help=f"axes to analyse (default: all six: {' '.join(AXES)})")
    p.add_argument("--topic", default=None, help="sensor_msgs/Imu topic (default: the only IMU topic)")
    p.add_argument("--out", default="identify_out", metavar="DIR", help="output directory (default: %(default)s)")
    p.add_argument("--refine", type=int, default=2, metavar="N",
                   help="grid-refinement passes: rerun with grids re-centred on the posterior (default: %(default)s)")
    p.add_argument("--no-plot", action="store_true", help="skip the PNG plot")
    p.set_defaults(run=run)


def identify_series(series: ImuSeries, axes: list[str], hypotheses: str | None, refine: int = 0) -> dict[str, Any]:
    """Run the bank on each axis of ``series`` (``refine`` grid-refinement passes); per-axis results."""
    from ..core.hypotheses.axis import identify_offline
    from ..core.hypotheses.config import hypothesis_set_factory
    from ..resources import read_hypotheses_file

    if len(series) < 2:
        raise InputError(f"{series.topic or 'the IMU series'} has {len(series)} sample(s): need a recording")
    dt = series.dt
    data, source = read_hypotheses_file(hypotheses)
    out: dict[str, Any] = {"source": source, "dt": dt, "axes": {}}
    for axis in axes:
        sensor = axis.split("_")[0]
        make, warmup = hypothesis_set_factory(data, dt, sensor, source)
        y = series.axis(axis)
        block = make(1.0).block
        every = max(1, len(y) // block // MAX_ROWS)
        result, ident, passes = identify_offline(y, make, warmup, dt, refine=refine, record_every=every)
        out["axes"][axis] = {"result": result, "offset": ident.offset, "hset": ident.bank.hset, "warmup": warmup,
                             "wn_estimate": ident.wn_estimate, "states": ident.bank.state_estimates(),
                             "passes": passes}
    return out


def _axis_yaml(axis: str, entry: dict[str, Any]) -> dict[str, Any]:
    result = entry["result"]
    hset = entry["hset"]
    final = result.final
    return {
        "unit": UNITS[axis],
        "decision": final.decision,
        "decision_time_s": result.decision_time,
        "duration_s": float(final.t),
        "probabilities": {k: float(v) for k, v in final.probabilities.items()},
        "offset_removed": float(entry["offset"]),
        "warmup_white_noise_estimate": entry["wn_estimate"],
        "passes": entry["passes"],
        "warmup_s": float(entry["warmup"]),
        "block": int(hset.block),
        "gamma": float(hset.gamma),
        "hypotheses": {
            name: {
                "probability": est.probability,
                "theta": est.theta,
                "theta_std": est.theta_std,
                "rsd": {k: (None if not np.isfinite(v) else v) for k, v in est.rsd.items()},
                "state": {s: v[0] for s, v in entry["states"][name].items()},
                "state_std": {s: v[1] for s, v in entry["states"][name].items()},
                "grid": {p.name: {"range": [p.low, p.high], "n": p.n, "spacing": p.spacing,
                                  "grid_range": [float(p.edges()[0]), float(p.edges()[-1])]}
                         for p in next(h for h in hset.hypotheses if h.name == name).priors},
            }
            for name, est in final.hypotheses.items()
        },
    }


def write_outputs(res: dict[str, Any], out_dir: Path, plot: bool = True) -> None:
    """``hypotheses.yaml``, ``hypotheses_probabilities.csv`` and (optionally) the PNG plot."""
    import yaml

    out_dir.mkdir(parents=True, exist_ok=True)
    doc = {"source_hypotheses": res["source"], "dt": res["dt"],
           "axes": {axis: _axis_yaml(axis, e) for axis, e in res["axes"].items()}}
    (out_dir / "hypotheses.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    lines = ["axis,t_s,hypothesis,probability"]
    for axis, e in res["axes"].items():
        r = e["result"]
        for k, name in enumerate(r.names):
            lines += [f"{axis},{t:.6g},{name},{p:.6g}" for t, p in zip(r.t, r.probabilities[:, k], strict=True)]
    (out_dir / "hypotheses_probabilities.csv").write_text("\n".join(lines) + "\n")
    if plot:
        from ..report.hypotheses_plots import plot_identify

        plot_identify(res, out_dir / "hypotheses_probabilities.png")


def run(args: argparse.Namespace) -> int:
    from ..bag.reader import read_imu

    series = read_imu(args.bag, topic=args.topic)
    if args.refine < 0:
        raise InputError(f"--refine must be >= 0, got {args.refine}")
    res = identify_series(series, list(dict.fromkeys(args.axis)), args.hypotheses, args.refine)
    out = Path(args.out)
    write_outputs(res, out, plot=not args.no_plot)
    for axis, e in res["axes"].items():
        f = e["result"].final
        probs = ", ".join(f"{k} {v:.3f}" for k, v in f.probabilities.items())
        print(f"{axis}: {probs} -> decision {f.decision or 'none yet'}")
    print(f"wrote {out / 'hypotheses.yaml'}")
    return 0
