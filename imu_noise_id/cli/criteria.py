"""``imu-noise-id criteria``: Monte-Carlo performance criteria of the hypothesis bank (paper 002 sections 3–4)."""

from __future__ import annotations

import argparse
import math
from typing import Any

from . import results_folder
from .options import add_out

#: Largest trials and samples per trial a run may ask for (memory and time).
MAX_TRIALS = 100_000
MAX_SAMPLES = 1e7


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "criteria",
        help="Monte-Carlo identification-error probability and parameter RSD of the Bayesian bank",
        description=(
            "Reproduce a case of Stepanov & Motorin (2019) section 4: RW vs GM hypotheses, trials drawing the "
            "true hypothesis and parameters from the priors, and as functions of time the real (eq. 15) and "
            "calculated (eq. 18) identification-error probabilities and the real (eq. 17) and calculated "
            "(eq. 19) relative standard deviations (eq. 20) of every parameter. Writes DIR/criteria.json and "
            "DIR/criteria_case<N>.png. Case 1: no white noise; case 2: sigma_v = 0.5 u known; case 3: "
            "sigma_v in [0.25, 1] u unknown. The paper does not state its sampling period; 0.1 s (the default) "
            "fits its case 1 and 2 results best (docs/hypotheses.md)."
        ),
    )
    p.add_argument("--case", type=int, choices=(1, 2, 3), required=True, help="paper 002 case")
    p.add_argument("--trials", type=int, default=500, help="Monte-Carlo trials L (default: %(default)s)")
    p.add_argument("--duration", type=float, default=2000.0, help="record length [s] (default: %(default)s)")
    p.add_argument("--dt", type=float, default=0.1, help="sampling period [s] (default: %(default)s)")
    p.add_argument("--bias-sigma", type=float, default=1.0,
                   help="prior std of the constant bias [u], truth drawn from it too (default: %(default)s)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default: %(default)s)")
    add_out(p, "criteria", per_bag=False)
    p.add_argument("--no-plot", action="store_true", help="skip the PNG plot")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..core.errors import InputError
    from ..core.hypotheses.criteria import paper_case, run_criteria
    from ..report.criteria_json import write_criteria_json

    if not 2 <= args.trials <= MAX_TRIALS:
        raise InputError(f"--trials must be between 2 and {MAX_TRIALS}, got {args.trials}")
    if not (math.isfinite(args.duration) and math.isfinite(args.dt) and args.duration > 0 and args.dt > 0):
        raise InputError("--duration and --dt must be finite and > 0 s")
    if args.duration / args.dt > MAX_SAMPLES:
        raise InputError(f"--duration / --dt = {args.duration / args.dt:.3g} samples per trial: at most "
                         f"{MAX_SAMPLES:g}; shorten --duration or raise --dt")
    from .progress import TextProgress

    hset = paper_case(args.case, dt=args.dt, bias_sigma=args.bias_sigma)
    with TextProgress(f"case {args.case}: {args.trials} trials", unit="trial-records") as progress:
        result = run_criteria(hset, args.duration, args.trials, seed=args.seed, case=str(args.case),
                              progress=progress)
    out = args.out
    folder = results_folder(args, None, None)
    with folder as staging:
        write_criteria_json(result, staging / "criteria.json")
        if not args.no_plot:
            from ..report.hypotheses_plots import plot_criteria

            plot_criteria([result], staging / f"criteria_case{args.case}.png", f"paper 002 case {args.case}")
    folder.report()
    print(f"case {args.case}, {args.trials} trials, dt {args.dt} s, at {result.t[-1]:g} s: identification error "
          f"real {result.error_probability_real[-1]:.3f}, calculated {result.error_probability_calculated[-1]:.3f}")
    for k, v in result.rsd_real.items():
        print(f"  RSD {k}: real {v[-1]:.3f}, calculated {result.rsd_calculated[k][-1]:.3f}")
    print(f"wrote {out / 'criteria.json'}")
    return 0
