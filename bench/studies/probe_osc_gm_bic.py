"""Whether bench_loop_effects' ``osc+gm`` case holds its GM: the likelihood gain of the true structure, fitted from
the truth, over the loop's WN+OSC+RW, against what BIC asks (docs/loop.md, "Limitations").

Run:  PYTHONPATH=$PWD nice -n 10 python bench/studies/probe_osc_gm_bic.py [--seeds 3] [--minutes 20 120]
(prints its findings; about a minute per 2 h record)

The GM (τ = 60 s, σ = 2·10⁻³) has, above its corner 1/(2πτ) = 2.7 mHz, the PSD of a random walk of density
σ·√(2/τ) = 3.65·10⁻⁴, more than the true K = 3·10⁻⁴: WN+OSC+RW takes both as one random walk of density
√(K² + 2σ²/τ) = 4.7·10⁻⁴ (+57 %). Per seed and record length: both structures fitted from the truth (the RW of
WN+OSC+RW from that combined density), their log-likelihoods, the gain Δℓ and the BIC threshold for the GM's two
parameters, ln N.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # bench/, for its shared helpers

from bench_loop_effects import DT, K_TRUE, N_TRUE, simulate

from imu_noise_id.core.estimation.em.model import FitOptions, fit_model
from imu_noise_id.core.noise.components import GM, RW, WN

GM_TRUE = GM(tau=60.0, sigma=2e-3)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--minutes", type=float, nargs="+", default=[20.0, 120.0])
    args = ap.parse_args()
    combined = math.sqrt(K_TRUE**2 + 2.0 * GM_TRUE.sigma**2 / GM_TRUE.tau)
    print(f"# bench/studies/probe_osc_gm_bic.py --seeds {args.seeds} "
          f"--minutes {' '.join(f'{m:g}' for m in args.minutes)}; "
          f"truth WN({N_TRUE}) + OSC + {GM_TRUE} + RW({K_TRUE}); combined RW density {combined:.3g}")
    options = FitOptions(uncertainty=False, n_starts=1)
    for minutes in args.minutes:
        n = int(minutes * 60 / DT)
        for seed in range(1000, 1000 + args.seeds):
            t0 = time.process_time()
            y, truth = simulate("osc+gm", seed, n)
            osc = truth["osc"]
            without = fit_model(y, DT, "WN+OSC+RW", init=[WN(N_TRUE), osc, RW(combined)], options=options)
            with_gm = fit_model(y, DT, "WN+OSC+GM+RW", init=[WN(N_TRUE), osc, GM_TRUE, RW(K_TRUE)], options=options)
            gm, rw = with_gm.components[2], with_gm.components[3]
            print(f"{minutes:5g} min seed {seed}: WN+OSC+RW K {without.components[2].random_walk:.3g}; "
                  f"WN+OSC+GM+RW GM tau {gm.tau:.3g} s sigma {gm.sigma:.3g}, K {rw.random_walk:.3g}; "
                  f"gain {with_gm.loglik - without.loglik:.2f}, BIC asks {math.log(n):.2f} "
                  f"({time.process_time() - t0:.0f} s CPU)", flush=True)


if __name__ == "__main__":
    main()
