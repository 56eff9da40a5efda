"""What scaling a zero-boundary parameter's search coordinate by ℓ_A's curvature along the ladder of starts buys the
profile intervals' inner maximisations (docs/em.md, "A zero-boundary parameter searched linearly").

Run:  PYTHONPATH=$PWD nice -n 10 python bench/studies/probe_inner_scaling.py [--long-seeds 2] [--short-seeds 8]
(about five minutes on a 2-core machine; ``run_all.py --studies`` keeps its output as a section of
docs/results/studies/likelihood_speed.txt)

``fit_model`` with intervals on WN+GM+RW+RR records: ``long``, 360 000 samples at 100 Hz of issue 46's T5 truth
(GM τ 5 s, RW 3e-5, a ramp; bench_fit_time's record); ``short``, 36 000 samples at 10 Hz of bench_coverage's
WN+GM+RW+RR truth (its seeds 1000 …). Every inner maximisation ``Profiler.maximise`` is run twice on the same starts,
without the scaling (``rung_curvature`` returning NaN: K/s as it was) and with it; the profile goes on from the
unscaled one. Per record set: the maximisations, their gradient passes (``mle.loglik_grad_profile``: the scored
starts are ℓ-only passes, the same both ways) and ℓ_A(scaled) − ℓ_A(unscaled) at the two argmaxes.
"""

from __future__ import annotations

import argparse
import math
import subprocess
from pathlib import Path

import numpy as np

from imu_noise_id.core.estimation.em import mle, profile
from imu_noise_id.core.estimation.em.model import FitOptions, fit_model
from imu_noise_id.core.noise.components import GM, RR, RW, WN, simulate_sum

#: A difference in ℓ_A beyond this is counted (the inner search stops at a projected gradient of 3e-2).
NOTABLE = 0.05


def records(kind: str, seeds: int):
    """(y, dt) of each record of ``kind`` (``long`` or ``short``)."""
    for seed in range(seeds):
        if kind == "long":
            truth = [WN(1e-3), GM(tau=5.0, sigma=1e-3), RW(3e-5), RR(1e-6)]
            yield simulate_sum(truth, 360_000, 0.01, np.random.default_rng(1 + seed)) + 2e-3, 0.01
        else:
            truth = [WN(1e-3), GM(tau=100.0, sigma=3e-4), RW(1e-5), RR(1e-7)]
            yield simulate_sum(truth, 36_000, 0.1, np.random.default_rng(1000 + seed)), 0.1


def compare(kind: str, seeds: int) -> str:
    curvature, maximise, grad = profile.rung_curvature, profile.Profiler.maximise, mle.loglik_grad_profile
    passes = [0]
    rows: list[tuple[float, int, int]] = []

    def counted(*args, **kwargs):
        passes[0] += 1
        return grad(*args, **kwargs)

    def both(self, starts, fixed, base, **kwargs):
        out = {}
        for label, rule in (("unscaled", lambda points: math.nan), ("scaled", curvature)):
            profile.rung_curvature = rule
            before = passes[0]
            out[label] = (maximise(self, starts, fixed, base, **kwargs), passes[0] - before)
        profile.rung_curvature = curvature
        rows.append((out["scaled"][0][0] - out["unscaled"][0][0], out["scaled"][1], out["unscaled"][1]))
        return out["unscaled"][0]

    mle.loglik_grad_profile, profile.Profiler.maximise = counted, both
    try:
        for y, dt in records(kind, seeds):
            fit_model(y, dt, "WN+GM+RW+RR", options=FitOptions(n_starts=2))
    finally:
        mle.loglik_grad_profile, profile.Profiler.maximise = grad, maximise
        profile.rung_curvature = curvature
    diff = np.array([r[0] for r in rows])
    return (f"{kind:5s} {seeds} records: {len(rows)} inner maximisations; gradient passes {sum(r[1] for r in rows)} "
            f"scaled against {sum(r[2] for r in rows)} unscaled; ℓ_A scaled − unscaled from {diff.min():+.3f} to "
            f"{diff.max():+.3f}, below −{NOTABLE} in {int(np.sum(diff < -NOTABLE))}, above +{NOTABLE} in "
            f"{int(np.sum(diff > NOTABLE))}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--long-seeds", type=int, default=2)
    ap.add_argument("--short-seeds", type=int, default=8)
    args = ap.parse_args()
    root = Path(__file__).resolve().parents[2]
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=root,
                            check=False).stdout.strip()
    print(f"# at {commit or 'unknown'}, one process, one BLAS thread")
    print(compare("long", args.long_seeds))
    print(compare("short", args.short_seeds))


if __name__ == "__main__":
    main()
