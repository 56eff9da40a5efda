"""How low K could go if a bounded wander the record can barely show stood beside it: the profile-likelihood lower
end of K when the loop's final model may also hold a GM (docs/loop.md, "Limitations"; why K's interval is not
widened by it).

Run:  PYTHONPATH=$PWD nice -n 10 python bench/studies/probe_k_bounded_wander.py [--seeds 10] [--minutes 20]
(prints its findings; about 10 s per record)

Per seed of bench_loop_effects' ``clean`` (WN + RW) and ``osc+gm`` (WN + OSC + RW + GM(τ = 60 s)) records: the loop
from WN+RW, its final K with the Wald interval ``analyze`` reports, and the lower end of K's 95 % profile interval
in the final model plus a GM whose corner frequency 1/(2πτ) lies at or above the record's third Fourier frequency
(τ ≤ T/(6π), 64 s at 20 min: a wander the record holds at least three frequencies below the corner of). The
likelihood is Whittle's on the record's differences (``core.estimation.whittle``: the tapered, banded periodogram),
the other components held at their fitted values (they live at higher frequencies), maximised over the GM's τ and σ
at each K; the interval is {K : max ℓ(K, ·) ≥ max ℓ − ½·3.84·35/18}, 35/18 being the Hann taper's inflation
n·Σw⁴/(Σw²)² of the log-likelihood ratio.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # bench/, for its shared helpers

import numpy as np
from bench_loop_effects import DT, K_TRUE, probe_arguments, simulate
from scipy.optimize import minimize

from imu_noise_id.core.estimation.em.relabel import with_uncertainty
from imu_noise_id.core.estimation.em.whittle import banded_periodogram, difference_spectrum
from imu_noise_id.core.estimation.readouts import kalibr
from imu_noise_id.core.noise.components import GM, RW, Component
from imu_noise_id.core.quality import interpolate_missing
from imu_noise_id.pipelines.loop import run_closed_loop

#: Hann taper: n·Σw⁴/(Σw²)², the factor by which the tapered Whittle log-likelihood ratio overstates the exact one.
TAPER_INFLATION = 35.0 / 18.0
CHI2_1_95 = 3.841458820694124
#: The GM's corner at or above this Fourier frequency of the record.
CORNER_BIN = 3.0


def k_lower_end(components: list[Component], y: np.ndarray, dt: float) -> tuple[float, float, float]:
    """(lower end of K's profile interval [u/s/√Hz], the GM's τ there [s], the Whittle gain of the GM at K̂)."""
    k_hat = next(c for c in components if isinstance(c, RW)).random_walk
    bp = banded_periodogram(interpolate_missing(y))
    tau_max = y.size * dt / (2.0 * math.pi * CORNER_BIN)
    tau_min = max(10.0 * dt, tau_max / 1000.0)
    fixed = difference_spectrum([c for c in components if not isinstance(c, RW)], bp.omega, dt)

    def loglik(k: float, x: np.ndarray | None) -> float:
        varying = [RW(k)] + ([GM(tau=math.exp(x[0]), sigma=math.exp(x[1]))] if x is not None else [])
        s = fixed + difference_spectrum(varying, bp.omega, dt)
        return -float(np.sum(bp.count * np.log(s) + bp.power / s))

    sigma_scale = k_hat * math.sqrt(tau_max)  # a GM whose short-term wander matches K̂'s over τ_max
    box = [(math.log(tau_min), math.log(tau_max)), (math.log(sigma_scale * 1e-4), math.log(sigma_scale * 1e3))]
    starts = [np.array([lt, math.log(sigma_scale * f)])
              for lt in np.linspace(box[0][0], box[0][1], 5) for f in (0.1, 1.0)]

    def profile(k: float) -> tuple[float, float]:
        best, tau = loglik(k, None), math.nan
        for x0 in starts:
            r = minimize(lambda x: -loglik(k, x), x0, method="L-BFGS-B", bounds=box)
            if -r.fun > best:
                best, tau = -float(r.fun), math.exp(r.x[0])
        return best, tau

    peak = max(profile(k)[0] for k in np.linspace(0.0, 1.5 * k_hat, 16))
    threshold = peak - 0.5 * CHI2_1_95 * TAPER_INFLATION
    gain = profile(k_hat)[0] - loglik(k_hat, None)
    if profile(0.0)[0] >= threshold:
        return 0.0, profile(0.0)[1], gain
    if profile(k_hat)[0] < threshold:  # the Whittle and exact maxima disagree: nothing below K̂ to report
        return k_hat, math.nan, gain
    lo, hi = 0.0, k_hat
    for _ in range(14):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if profile(mid)[0] >= threshold else (mid, hi)
    return hi, profile(hi)[1], gain


def main() -> None:
    args, n = probe_arguments(__doc__)
    print(f"# bench/studies/probe_k_bounded_wander.py --seeds {args.seeds} --minutes {args.minutes:g} ({n} samples at "
          f"100 Hz; true K = {K_TRUE}; GM τ ≤ {n * DT / (2 * math.pi * CORNER_BIN):.3g} s)")
    for case in ("clean", "osc+gm"):
        wald_holds = low_holds = zero = 0
        ratios = []
        for s in range(args.seeds):
            start = time.perf_counter()
            y, _ = simulate(case, 1000 + s, n)
            loop = run_closed_loop(y, DT, "WN+RW")
            fit = with_uncertainty(loop.final.diagnosis.fit)
            k = kalibr.random_walk(fit)
            y_fit, z = fit.record
            low, tau, gain = k_lower_end(list(fit.components), y_fit - z @ fit.statespace.b, DT)
            wald_holds += k.ci95[0] <= K_TRUE <= k.ci95[1]
            low_holds += min(low, k.ci95[0]) <= K_TRUE <= k.ci95[1]
            zero += low == 0.0
            ratios.append(low / k.value)
            print(f"  {case:6s} seed {1000 + s}: {loop.final.model:22s} K {k.value:.3g} Wald [{k.ci95[0]:.3g}, "
                  f"{k.ci95[1]:.3g}]; with a bounded wander down to {low:.3g} (GM τ {tau:.3g} s; Whittle gain of the "
                  f"GM at K̂ {gain:.2f}) ({time.perf_counter() - start:.0f} s)", flush=True)
        print(f"{case}: the truth inside the Wald interval {wald_holds} of {args.seeds}, inside [lower end, Wald "
              f"upper] {low_holds} of {args.seeds}; lower end 0 in {zero}, median lower end / K "
              f"{np.median(ratios):.2f}", flush=True)


if __name__ == "__main__":
    main()
