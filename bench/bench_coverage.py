"""Coverage of the 95 % intervals of fit_model for several component mixes (seeded Monte Carlo).

Run:  nice -n 10 python bench/bench_coverage.py [--runs 40]   (output in docs/results/bench_coverage.txt)

For each mix, records are simulated from the truth and fitted with the default pipeline; the share of runs
whose interval contains the truth is printed per parameter (nominal 95 %; with 40 runs a share below ~85 %
is a real defect, 85–100 % is consistent with 95 %), with the median relative width of the intervals.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from imu_noise_id.core.estimation.model import FitOptions, fit_model
from imu_noise_id.core.noise.components import GM, QN, RR, RW, WN, simulate_sum
from imu_noise_id.core.noise.modelspec import parameter_labels

MIXES = {
    "WN+RW+RR": ([WN(0.2), RW(0.01), RR(2e-4)], 4000, 1.0),
    "WN+GM": ([WN(1e-3), GM(tau=0.2, sigma=1e-3)], 6000, 0.01),
    "WN+GM+RW": ([WN(1e-3), GM(tau=0.3, sigma=2e-3), RW(1e-3)], 6000, 0.01),
    "WN+2GM": ([WN(0.3), GM(tau=3.0, sigma=0.6), GM(tau=60.0, sigma=0.4)], 6000, 1.0),
    "WN+QN+GM": ([WN(0.3), QN(0.4), GM(tau=20.0, sigma=0.5)], 4000, 1.0),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=40)
    args = ap.parse_args()
    for spec, (truth, n, dt) in MIXES.items():
        t0 = time.perf_counter()
        labels = parameter_labels(truth)
        hits = {lab: 0 for _, _, lab in labels}
        widths: dict[str, list[float]] = {lab: [] for _, _, lab in labels}
        done = 0
        for run in range(args.runs):
            y = simulate_sum(truth, n, dt, np.random.default_rng(1000 + run)) + 0.1
            fit = fit_model(y, dt, spec, options=FitOptions(n_starts=2))
            done += 1
            for i, p, lab in labels:
                value = truth[i].params()[p]
                lo, hi = fit.ci95[lab]
                hits[lab] += lo <= value <= hi
                widths[lab].append((hi - lo) / abs(value))
        print(f"== {spec}: N = {n}, dt = {dt} s, {done} runs, {time.perf_counter() - t0:.0f} s ==")
        for _, _, lab in labels:
            print(f"  {lab:>18}: coverage {100.0 * hits[lab] / done:5.1f} %   median relative width "
                  f"{np.median(widths[lab]):.3g}")


if __name__ == "__main__":
    main()
