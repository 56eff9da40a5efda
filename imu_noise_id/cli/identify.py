"""``imu-noise-id identify BAG``: recursive Bayesian hypothesis probabilities per axis (paper 002)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ..core.axes import AXES


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


def run(args: argparse.Namespace) -> int:
    from ..bag.reader import read_imu
    from ..pipelines.identify import identify
    from ..report.hypotheses_yaml import write_identification
    from ..resources import read_hypotheses_file

    hypotheses, source = read_hypotheses_file(args.hypotheses)
    series = read_imu(args.bag, topic=args.topic)
    res = identify(series, list(dict.fromkeys(args.axis)), hypotheses, source, args.refine)
    out = Path(args.out)
    write_identification(res, out)
    if not args.no_plot:
        from ..report.hypotheses_plots import plot_identify

        plot_identify(res, out / "hypotheses_probabilities.png")
    for axis, e in res.axes.items():
        f = e.result.final
        probs = ", ".join(f"{k} {v:.3f}" for k, v in f.probabilities.items())
        print(f"{axis}: {probs} -> decision {f.decision or 'none yet'}")
        for g in f.long_memory:
            print(f"  {g.text()}")
    print(f"wrote {out / 'hypotheses.yaml'}")
    return 0
