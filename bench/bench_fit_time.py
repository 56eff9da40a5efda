"""Wall time of one structure's fit with its intervals (``imu-noise-id fit --model WN+GM+RW+RR``), side by side.

Each record length is fitted by every checkout given, one after the other in the same run, each in its own process
(``common.run_in_checkout``, one BLAS thread)::

    .venv/bin/python bench/bench_fit_time.py --samples 360000 --baseline ../baseline
    .venv/bin/python bench/bench_fit_time.py --samples 10000000

The committed output holds these two runs: 1 h side by side with the checkout before the profile end search's two
changes, then 27.8 h by this checkout alone; each section's second line names its checkouts.

The record: WN(1e-3) + GM(τ 5 s, σ 1e-3) + RW(3e-5) + RR(1e-6) at 100 Hz (``bench_em``'s truth), simulated in the
child from a fixed seed (not timed). Timed: ``NoiseModel(y, dt, "WN+GM+RW+RR").fit()``, the point estimate with its
95 % intervals as ``fit`` computes them. Printed per length and checkout: wall time, the exact log-likelihood, how
many parameters got a profile interval and how many an interval the profile budget chose instead.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from common import run_in_checkout  # bench/common.py, beside this script

ROOT = Path(__file__).resolve().parents[1]

CODE = """
import json, time
import numpy as np
from imu_noise_id.core.estimation.em.model import NoiseModel
from imu_noise_id.core.noise.components import GM, RR, RW, WN, simulate_sum
y = simulate_sum([WN(1e-3), GM(tau=5.0, sigma=1e-3), RW(3e-5), RR(1e-6)], {n}, 0.01, np.random.default_rng(1)) + 2e-3
start = time.perf_counter()
fit = NoiseModel(y, 0.01, "WN+GM+RW+RR").fit()
wall = time.perf_counter() - start
methods = list(fit.ci95_method.values())
print(json.dumps({{"wall": wall, "loglik": fit.loglik, "profiles": sum(m == "profile" for m in methods),
                  "budget": sum("budget" in m for m in methods), "parameters": len(methods)}}))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, nargs="+", default=[360_000, 10_000_000])
    ap.add_argument("--baseline", type=Path, default=None, help="another checkout, run side by side")
    args = ap.parse_args()
    sources = [("this checkout", ROOT)] + ([(f"baseline {args.baseline}", args.baseline.resolve())]
                                          if args.baseline else [])
    print("fit --model WN+GM+RW+RR with intervals, one process per fit, one BLAS thread")
    for n in args.samples:
        print(f"\n{n} samples at 100 Hz ({n / 360_000:.3g} h):")
        walls = {}
        for label, source in sources:
            _, r = run_in_checkout(source, CODE.format(n=n), f"the fit of {n} samples")
            walls[label] = r["wall"]
            print(f"  {label:40s} wall {r['wall']:8.1f} s   log-likelihood {r['loglik']:.2f}   intervals: "
                  f"{r['profiles']} profile, {r['budget']} by the budget, of {r['parameters']}", flush=True)
        if len(walls) == 2:
            (a, wa), (b, wb) = walls.items()
            print(f"  {b}: {wb / wa:.2f}× the wall time of {a}")


if __name__ == "__main__":
    main()
