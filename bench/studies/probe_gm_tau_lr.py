"""Whether the χ²₁ calibration of issue 12's GM τ intervals holds (docs/em.md, "Interval coverage"): the LR statistic
in bootstrap records.

It came out nominal (with the inner maximisations of its time, started at the estimate), which ruled out a
Bartlett-type correction. The under-coverage it was written to explain came from the profile search itself (fixed
in f362b8c): its inner maximisations never left the K ≈ 0 branch, so intervals ended where ℓ_A was still high.

Run:  nice -n 10 python bench/studies/probe_gm_tau_lr.py   (prints its findings; ~15 min)

For four records of bench_coverage.py's WN+GM+RW+RR (seeds 1001 and 1030, whose fits lie near or below the true
τ = 100 s; 1027 and 1052, on the long-τ branch with K ≈ 0), the fit's adjusted-profile machinery
(:class:`imu_noise_id.core.estimation.em.profile.Profiler`, captured when the fit profiles GM τ) is reused on
``--boot`` records simulated from the estimate. In each, W* = 2(max ℓ_A − max ℓ_A at τ = τ̂) with both
maximisations started at the estimate only ("local"), or the free one from five starts (τ̂·3^{0,±1} with K at its
zero-boundary scale s and at s·e⁻⁸) and the held one from the estimate and the same K values ("five starts").
E[W*] is the Bartlett factor a calibration would use; P(W* > 3.84) should be 5 % where χ²₁ holds. Then, for seed 1001,
``--truth`` records simulated from the truth with W at the true τ, local maximisations from the truth.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

import imu_noise_id.core.estimation.em.uncertainty as uncertainty
from imu_noise_id.core.estimation.em.model import FitOptions, fit_model
from imu_noise_id.core.estimation.em.profile import Profiler
from imu_noise_id.core.noise.components import GM, RR, RW, WN, simulate_sum

TRUTH = [WN(1e-3), GM(tau=100.0, sigma=3e-4), RW(1e-5), RR(1e-7)]
N, DT = 36_000, 0.1


def _captured(seed: int) -> tuple[object, Profiler, int, int]:
    """The fit of one coverage record and its Profiler at the GM τ interval, with the indices of τ and K."""
    seen: list[tuple[Profiler, int]] = []
    original = uncertainty.Profiler.interval

    def spy(self, k, cov, *args, **kwargs):
        i, name = self.par.entries[k]
        if self.par.template[i].name == "GM" and name == "tau":
            seen.append((self, k))
        return original(self, k, cov, *args, **kwargs)

    uncertainty.Profiler.interval = spy
    try:
        y = simulate_sum(TRUTH, N, DT, np.random.default_rng(seed)) + 0.1
        fit = fit_model(y, DT, "WN+GM+RW+RR", options=FitOptions(n_starts=2))
    finally:
        uncertainty.Profiler.interval = original
    prof, k = seen[0]
    k_rw = next(j for j, (i, _) in enumerate(prof.par.entries) if prof.par.template[i].name == "RW")
    return fit, prof, k, k_rw


def _statistic(prof: Profiler, theta: np.ndarray, y: np.ndarray, k: int, starts: list[np.ndarray],
               held_starts: list[np.ndarray]) -> float:
    boot = Profiler(prof.par, theta, prof.model, y, prof.z, 0.0, prof.info, prof.lo, prof.hi, zero=dict(prof.zero),
                    flat=set(prof.flat))
    boot.ll_max = boot.evaluate(theta)[0]
    free = max(boot.maximise([s], set(), prof.model)[0] for s in starts)
    held = max(boot.maximise([s], {k}, prof.model)[0] for s in held_starts)
    return 2.0 * max(free - held, 0.0)


def _starts(prof: Profiler, theta: np.ndarray, k: int, k_rw: int) -> tuple[list, list]:
    base_k = math.log(prof.zero[k_rw]) if k_rw in prof.zero else float(theta[k_rw])
    free, held = [theta], [theta]
    for shift in (math.log(3.0), -math.log(3.0)):
        for k_value in (base_k, base_k - 8.0):
            th = theta.copy()
            th[k] = np.clip(th[k] + shift, prof.lo[k], prof.hi[k])
            th[k_rw] = k_value
            free.append(th)
    for k_value in (base_k, base_k - 8.0):
        th = theta.copy()
        th[k_rw] = k_value
        held.append(th)
    return free, held


def _summary(w: list[float]) -> str:
    a = np.asarray(w)
    return (f"E[W*] {a.mean():.2f} ± {a.std(ddof=1) / math.sqrt(a.size):.2f}, P(W* > 3.84) {np.mean(a > 3.84):.2f}, "
            f"95 % quantile {np.quantile(a, 0.95):.2f} ({a.size} records)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="1001,1030,1027,1052")
    ap.add_argument("--boot", type=int, default=40)
    ap.add_argument("--truth", type=int, default=100)
    args = ap.parse_args()
    t0 = time.perf_counter()
    print(f"# bench/studies/probe_gm_tau_lr.py --seeds {args.seeds} --boot {args.boot} --truth {args.truth}; "
          f"truth {' + '.join(map(str, TRUTH))}, N = {N}, dt = {DT} s")
    for seed in (int(s) for s in args.seeds.split(",")):
        fit, prof, k, k_rw = _captured(seed)
        noise = [c for c in prof.par.to_components(prof.theta, prof.model) if not isinstance(c, RR)]
        free, held = _starts(prof, prof.theta, k, k_rw)
        local, five = [], []
        rng = np.random.default_rng(seed)
        for _ in range(args.boot):
            y = simulate_sum(noise, N, DT, rng)
            local.append(_statistic(prof, prof.theta, y, k, [prof.theta], [prof.theta]))
            five.append(_statistic(prof, prof.theta, y, k, free, held))
        lo, hi = fit.ci95["GM.tau"]
        print(f"seed {seed}: tau_hat {math.exp(prof.theta[k]):.1f} s, K_hat {math.exp(prof.theta[k_rw]):.3g}, "
              f"interval [{lo:.3g}, {hi:.3g}] s", flush=True)
        print(f"    local      {_summary(local)}", flush=True)
        print(f"    five starts {_summary(five)}", flush=True)
        if seed == 1001 and args.truth:
            theta = prof.par.to_theta([c for c in TRUTH])
            noise = [c for c in TRUTH if not isinstance(c, RR)]
            w = [_statistic(prof, theta, simulate_sum(noise, N, DT, rng), k, [theta], [theta])
                 for _ in range(args.truth)]
            print(f"    from the truth, W at the true tau, local: {_summary(w)}", flush=True)
    print(f"# total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
