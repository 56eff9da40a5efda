"""Coverage of the long-τ random-walk bound (core/allan/rw_bound.py): how often a true random walk is flagged.

Usage (from the repository root)::

    PYTHONPATH=$PWD python bench/bench_rw_bound.py [--seeds 1000] [--out docs/results/bench_rw_bound.txt]

For each case, ``--seeds`` simulated records with a known random walk K: the share in which the simultaneous 95 %
bound (what ``analyze`` flags a final K by) lies below the true K, beside the share for the minimum of pointwise
95 % limits (what ``bench/loop_measured.py`` printed as its 95 % bound before) and for the point bound; the median
bound over K (how wide it is). The AV is read from a tenth of the record to half of it, as ``analyze`` does.

Cases: a random walk alone (what the bound's simultaneity is calibrated on: every other noise adds AV); WN + RW
dominating the long τ; WN + RW where the white noise still holds half the AV at a tenth of the
record; WN + GM + RW (a bounded process beside the walk, which only adds AV); and each on 1000 s and 1 h records.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from common import long_tau_rw_bounds  # bench/common.py, beside this script

from imu_noise_id.core.noise.components import GM, RW, WN, simulate_sum

DT = 0.1
CASES = {
    "RW alone (the least favourable case)": [WN(1e-6), RW(1e-3)],
    "WN+RW (RW dominates τ ≥ T/10)": [WN(2e-3), RW(1e-3)],
    "WN+RW (WN half of the AV at T/10)": [WN(1e-2), RW(1e-4)],
    "WN+GM+RW (GM τ 30 s)": [WN(2e-3), GM(tau=30.0, sigma=5e-3), RW(1e-3)],
}


def shares(model: list, n: int, seeds: int) -> tuple[float, float, float, float]:
    """(simultaneous, minimum of pointwise, point: share below the true K; median simultaneous bound / K)."""
    k = next(c.random_walk for c in model if isinstance(c, RW))
    simultaneous, pointwise, point = [], [], []
    for seed in range(seeds):
        bounds = long_tau_rw_bounds(simulate_sum(model, n, DT, np.random.default_rng(seed)), DT,
                                    tau_min=0.1 * n * DT)
        simultaneous.append(bounds["rw_bound95"])
        pointwise.append(bounds["rw_bound95_pointwise"])
        point.append(bounds["rw_bound"])
    below = [float(np.mean(np.array(b) < k)) for b in (simultaneous, pointwise, point)]
    return below[0], below[1], below[2], float(np.median(simultaneous)) / k


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=1000)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    lines = [f"# bench/bench_rw_bound.py --seeds {args.seeds}: records at {1 / DT:g} Hz; share of records whose bound "
             "lies below the true K (a false flag of a true random walk; 0.05 allowed at 95 %)",
             f"{'case':37s} {'record':>7s}   simultaneous 95 %   min of pointwise 95 %   point   median bound / K"]
    for name, model in CASES.items():
        for seconds in (1000, 3600):
            n = int(seconds / DT)
            sim, pw, pt, width = shares(model, n, args.seeds)
            lines.append(f"{name:37s} {seconds:6d}s   {sim:17.3f}   {pw:21.3f}   {pt:5.3f}   {width:16.2f}")
            print(lines[-1], flush=True)
    text = "\n".join(lines) + "\n"
    print(text if args.out is None else "", end="")
    if args.out is not None:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
