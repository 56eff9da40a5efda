"""The screen on statistics of fixed size against the exact fits it stands in for.

For simulated 1 h, 100 Hz records (360 000 samples; clean WN + RW, a GM of 2 s, 60 s and 300 s beside it, flicker
noise strong and weak), the closed loop's joint-search moves from a WN + RW fit — a GM at a tenth of the record and
flicker noise at the long-τ level, the random walk restarted small — are fitted exactly (from the move's start and
from the estimator's own starts, the better kept, as the loop's refit does) and screened
(:func:`imu_noise_id.core.estimation.em.screen.screen`). Printed per record and move: the exact log-likelihood gain and
ΔBIC, the screen's gain, which statistic gave it, its ΔBIC and verdict, the seconds each took; a MISS where the exact
fit lowers the BIC and the screen refuses the move. Also the banded Whittle likelihood from the move's own start
alone, the screen this one replaces::

    .venv/bin/python bench/bench_screen.py --seeds 1 2      # → docs/results/bench_screen.txt
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from imu_noise_id.core.estimation.em import screen
from imu_noise_id.core.estimation.em.model import FitOptions, NoiseModel
from imu_noise_id.core.noise.components import GM, RW, WN, simulate_sum
from imu_noise_id.core.noise.flicker import BI, band_for_record


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--rate", type=float, default=100.0)
    parser.add_argument("--duration", type=float, default=3600.0)
    args = parser.parse_args(argv)
    dt, n = 1.0 / args.rate, int(args.rate * args.duration)
    band = band_for_record(n, dt)
    truths = {"clean": [WN(1.7e-4), RW(2e-5)], "gm 2 s": [WN(1.7e-4), GM(2, 3e-4), RW(2e-5)],
              "gm 60 s": [WN(1.7e-4), GM(60, 4e-4), RW(2e-5)], "gm 300 s": [WN(1.7e-4), GM(300, 1.5e-4), RW(2e-5)],
              "flicker": [WN(1.7e-4), BI(1e-4, *band), RW(2e-5)],
              "weak flicker": [WN(1.7e-4), BI(3e-5, *band), RW(2e-5)]}
    options = FitOptions(uncertainty=False)
    print(f"{args.duration:g} s at {args.rate:g} Hz ({n} samples); screen margin ΔBIC < {screen.MARGIN:g}")
    print(f"{'record':13s} {'seed':>4s} {'move':9s} {'exact gain':>10s} {'ΔBIC':>7s} {'s':>5s} | {'screen gain':>11s} "
          f"{'statistic':10s} {'ΔBIC':>7s} {'exact fit?':10s} {'s':>5s} | {'Whittle alone':>13s}")
    misses = passes = total = 0
    exact_s = screen_s = 0.0
    for name, truth in truths.items():
        for seed in args.seeds:
            y = simulate_sum(truth, n, dt, np.random.default_rng(seed))
            current = NoiseModel(y, dt, "WN+RW").fit(options=options)
            t0 = time.perf_counter()
            stats = screen.Statistics.of(y, dt)
            reference = screen.Reference.fit(current.components, stats)
            ref_s = time.perf_counter() - t0
            walk = current.components[1].random_walk
            level = walk**2 * n * dt / 30.0
            moves = {"WN+GM+RW": [current.components[0], GM(n * dt / 10.0, math.sqrt(level / 0.38)), RW(walk * 1e-2)],
                     "WN+BI+RW": [current.components[0], BI(math.sqrt(level / 0.664), *band), RW(walk * 1e-2)]}
            for spec, start in moves.items():
                t0 = time.perf_counter()
                gain = max(NoiseModel(y, dt, spec).fit(init=start, options=options).loglik,
                           NoiseModel(y, dt, spec).fit(options=options).loglik) - current.loglik
                t_exact = time.perf_counter() - t0
                t0 = time.perf_counter()
                verdict = screen.screen(reference, start, stats)
                t_screen = time.perf_counter() - t0 + ref_s / len(moves)
                whittle_alone = stats.whittle_fit(start)[0] - reference.whittle_loglik
                delta = -2.0 * gain + verdict.extra_parameters * math.log(n)
                miss = delta < 0 and not verdict.worth_exact_fit
                misses, passes, total = misses + miss, passes + verdict.worth_exact_fit, total + 1
                exact_s, screen_s = exact_s + t_exact, screen_s + t_screen
                print(f"{name:13s} {seed:4d} {spec:9s} {gain:10.2f} {delta:7.1f} {t_exact:5.1f} | {verdict.gain:11.2f} "
                      f"{verdict.statistic:10s} {verdict.delta_bic:7.1f} "
                      f"{'yes' if verdict.worth_exact_fit else 'no':10s} {t_screen:5.1f} | {whittle_alone:13.2f}"
                      f"{'   MISS' if miss else ''}", flush=True)
    print(f"\n{total} moves: {passes} sent to the exact fit, {misses} missed (exact ΔBIC < 0 but refused); "
          f"exact fits {exact_s:.0f} s, screens {screen_s:.0f} s ({exact_s / screen_s:.1f}× the time) side by side")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
