"""Where the loop ends with flicker noise (BI) and neither a random walk nor a GM on bench_loop_effects' short-GM
cases: the BIC of replacing the flicker by a GM and a random walk in one move (docs/loop.md, joint search).

Run:  PYTHONPATH=$PWD nice -n 10 python bench/studies/probe_flicker_gm_rw.py \
          [--cases osc+clear_gm osc+fast_gm] [--seeds 10]
(prints its findings; a minute or two per record)

Per seed: the final model and BIC of the loop without that move (the joint search's third trial switched off, as
before a83961c); where it holds BI without RW or GM, the pair fitted from two starts — the
GM from the AV the flicker carries and the walk from the long-τ AV (what the joint search does), and the truth —
with the BIC difference (negative: the pair fits better), the fitted K and GM (τ [s], σ).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # bench/, for its shared helpers

import numpy as np
from bench_loop_effects import DT, GMS, K_TRUE, simulate

from imu_noise_id.core.noise.components import GM, RW
from imu_noise_id.pipelines.loop import run_closed_loop, trials
from imu_noise_id.pipelines.loop.steps import AxisLoop, _canonical
from imu_noise_id.pipelines.loop.trials import flicker_as_gm_and_walk


def loop_without_the_move(y: np.ndarray):
    """The closed loop with the joint search's flicker → GM + RW trial switched off."""
    trials.flicker_as_gm_and_walk = lambda loop, diag: None
    try:
        return run_closed_loop(y, DT, "WN+RW", axis="x")
    finally:
        trials.flicker_as_gm_and_walk = flicker_as_gm_and_walk


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", nargs="+", default=["osc+clear_gm", "osc+fast_gm"], choices=sorted(GMS))
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--minutes", type=float, default=20.0)
    args = ap.parse_args()
    n = int(args.minutes * 60 / DT)
    for case in args.cases:
        for s in range(args.seeds):
            t0 = time.perf_counter()
            y, _ = simulate(case, 1000 + s, n)
            r = loop_without_the_move(y)
            diag, state = r.final.diagnosis, r.final.state
            line = f"{case} seed {1000 + s}: {r.final.model} BIC {diag.errors.bic:.1f}"
            loop = AxisLoop(y, DT, None, alpha=0.01, lags=20, outliers="impute")
            start = flicker_as_gm_and_walk(loop, diag)
            if start is not None:
                rest = [c for c in start if not isinstance(c, GM | RW)]
                for label, init in (("AV start", start), ("truth start", _canonical([*rest, GMS[case], RW(K_TRUE)]))):
                    gm0 = next(c for c in init if isinstance(c, GM))
                    trial = state.with_components(init)
                    d = loop.diagnose(trial)
                    k = [c.random_walk for c in d.fit.components if isinstance(c, RW)]
                    gms = [(round(c.tau, 3), round(c.sigma, 5)) for c in d.fit.components if isinstance(c, GM)]
                    line += (f"\n   {label} (GM tau {gm0.tau:.3g} sigma {gm0.sigma:.3g}): {trial.name()} BIC "
                             f"{d.errors.bic:.1f} dBIC {d.errors.bic - diag.errors.bic:+.1f} K {k[0] if k else None} "
                             f"GM {gms}")
            print(line, f"({time.perf_counter() - t0:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
