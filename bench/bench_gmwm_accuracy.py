"""GMWM against the EM on simulated mixes: bias, RMSE and 95 % interval coverage per parameter (issue 14, target 1).

Run:  nice -n 10 python bench/bench_gmwm_accuracy.py [--runs 100] [--n 8192]
      (output in docs/results/bench_gmwm_accuracy.txt)

For each mix, ``--runs`` records of ``--n`` samples (dt = 1 s, so τ is in samples) are simulated from the truth with
seeds 5000 + run and fitted with the right structure by the EM (``fit_model``, 2 starts, the default pipeline of
bench_coverage.py) and by the GMWM (``fit_gmwm``, defaults: classical WV, scales up to N/8, two-step efficient
weight, Wald or profile intervals). Per parameter: the mean relative error (bias) and the RMSE relative to the truth,
the GMWM/EM RMSE ratio (> 1: the GMWM is less efficient) and the share of runs whose 95 % interval holds the truth.
An RR's slope is compared with its sign (the GMWM reports the record's least-squares slope). Records are
short so that the 2 × 500 fits run in well under an hour on the shared 2-core machine; the record length is printed
with each mix.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from imu_noise_id.core.errors import InputError
from imu_noise_id.core.estimation.em.model import FitOptions, fit_model
from imu_noise_id.core.estimation.gmwm.fit import fit_gmwm
from imu_noise_id.core.noise.components import GM, QN, RR, RW, WN, simulate_sum
from imu_noise_id.core.noise.modelspec import parameter_labels

MIXES = {
    "WN+RW": [WN(0.3), RW(0.01)],
    "WN+GM+RW": [WN(0.3), GM(tau=20.0, sigma=0.5), RW(0.005)],
    "WN+2GM": [WN(0.3), GM(tau=3.0, sigma=0.6), GM(tau=100.0, sigma=0.4)],
    "WN+GM+RW+RR": [WN(0.3), GM(tau=20.0, sigma=0.5), RW(0.005), RR(2e-4)],
    "WN+QN+RW": [WN(0.3), QN(0.4), RW(0.01)],
}


def _value(comps, i: int, p: str) -> float:
    return comps[i].params()[p]


def run_mix(spec: str, truth, runs: int, n: int) -> None:
    labels = parameter_labels(truth)
    est = {"EM": {lab: [] for *_, lab in labels}, "GMWM": {lab: [] for *_, lab in labels}}
    hit = {"EM": {lab: 0 for *_, lab in labels}, "GMWM": {lab: 0 for *_, lab in labels}}
    seconds = {"EM": 0.0, "GMWM": 0.0}
    failed = {"EM": 0, "GMWM": 0}
    t_mix = time.perf_counter()
    for run in range(runs):
        y = simulate_sum(truth, n, 1.0, np.random.default_rng(5000 + run)) + 0.1
        for name in ("EM", "GMWM"):
            t0 = time.perf_counter()
            try:
                fit = (fit_model(y, 1.0, spec, options=FitOptions(n_starts=2)) if name == "EM"
                       else fit_gmwm(y, 1.0, spec))
            except InputError:
                failed[name] += 1
                continue
            seconds[name] += time.perf_counter() - t0
            for i, p, lab in labels:
                # EM and GMWM list GMs in the structure's order; GM1 is matched with the faster one in both.
                comps = sorted(fit.components, key=lambda c: (c.name, c.params().get("tau", 0.0)))
                ref = sorted(truth, key=lambda c: (c.name, c.params().get("tau", 0.0)))
                j = next(k for k, c in enumerate(ref) if c is truth[i])
                est[name][lab].append(_value(comps, j, p) / _value(truth, i, p))
                lo, hi = fit.ci95[lab]
                hit[name][lab] += lo <= _value(truth, i, p) <= hi
    done = {k: runs - v for k, v in failed.items()}
    print(f"== {spec}: N = {n} samples (dt = 1 s), {runs} runs, {time.perf_counter() - t_mix:.0f} s; mean fit time "
          f"EM {seconds['EM'] / max(done['EM'], 1):.2f} s, GMWM {seconds['GMWM'] / max(done['GMWM'], 1):.2f} s; "
          f"failed fits EM {failed['EM']}, GMWM {failed['GMWM']} ==")
    print(f"  {'parameter':>18} {'truth':>9} | {'EM bias':>8} {'EM RMSE':>8} {'cov':>6} | {'GMWM bias':>9} "
          f"{'GMWM RMSE':>9} {'cov':>6} | RMSE GMWM/EM")
    for i, p, lab in labels:
        row = []
        for name in ("EM", "GMWM"):
            r = np.asarray(est[name][lab])
            cover = 100.0 * hit[name][lab] / max(done[name], 1)
            row.append((np.mean(r - 1.0), math.sqrt(np.mean((r - 1.0) ** 2)), cover))
        (be, re_, ce), (bg, rg, cg) = row
        print(f"  {lab:>18} {_value(truth, i, p):9.3g} | {be:+8.3f} {re_:8.3f} {ce:5.1f}% | {bg:+9.3f} {rg:9.3f} "
              f"{cg:5.1f}% | {rg / re_:6.2f}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--n", type=int, default=8192, help="samples per record")
    ap.add_argument("--mixes", default=",".join(MIXES), help="comma list of mixes")
    args = ap.parse_args()
    t0 = time.perf_counter()
    print(f"# bench_gmwm_accuracy.py --runs {args.runs} --n {args.n}; bias = mean(estimate/truth − 1), RMSE of "
          "estimate/truth − 1, cov = share of 95 % intervals holding the truth")
    for spec in args.mixes.split(","):
        run_mix(spec, MIXES[spec], args.runs, args.n)
    print(f"# total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
