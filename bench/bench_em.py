"""Speed of the EM + quasi-Newton fit vs statsmodels' MLE on WN+GM+RW+RR (issue 3's speed goal).

Run:  nice -n 10 python bench/bench_em.py [--quick]  (prints everything; the repo keeps its output in
docs/results/bench_em.txt). Goal on 1 h at 100 Hz (360 000 samples): wall time to convergence ≤ 2 s,
≥ 30× faster than statsmodels, log-likelihood ≥ statsmodels' − 0.5, time linear in N.

Both likelihoods are compared on one yardstick: this package's exact log-likelihood (bias and ramp profiled)
evaluated at each method's estimates; statsmodels' own llf uses a diffuse initial state and is printed too.
"""

from __future__ import annotations

import argparse
import os
import time
import warnings

import numpy as np

from imu_noise_id.core import kalman
from imu_noise_id.core.estimation.em.model import FitOptions, fit_model
from imu_noise_id.core.kalman import statespace as ss
from imu_noise_id.core.noise.components import GM, RR, RW, WN, simulate_sum

DT = 0.01
TRUTH = [WN(1e-3), GM(tau=5.0, sigma=1e-3), RW(3e-5), RR(1e-6)]


def simulate(n: int, seed: int = 1) -> np.ndarray:
    return simulate_sum(TRUTH, n, DT, np.random.default_rng(seed)) + 2e-3


def our_fit(y: np.ndarray, **kw):
    t0, c0 = time.perf_counter(), time.process_time()
    fit = fit_model(y, DT, "WN+GM+RW+RR", options=FitOptions(uncertainty=False, **kw))
    our_fit.cpu = time.process_time() - c0
    return fit, time.perf_counter() - t0


def exact_loglik(components, y: np.ndarray) -> float:
    model = ss.from_components(components, DT)
    z = np.column_stack([np.ones(y.size), DT * np.arange(y.size)])
    return kalman.loglik(model, y, z).loglik


def statsmodels_fit(y: np.ndarray):
    from statsmodels.tsa.statespace.structural import UnobservedComponents

    mod = UnobservedComponents(y, level="lldtrend", autoregressive=1)
    t0, c0 = time.perf_counter(), time.process_time()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = mod.fit(disp=False)
    elapsed = time.perf_counter() - t0
    statsmodels_fit.cpu = time.process_time() - c0
    p = dict(zip(mod.param_names, res.params, strict=True))
    phi = float(np.clip(p["ar.L1"], 1e-9, 1 - 1e-12))
    comps = [
        WN.from_per_sample(DT, sigma2_wn=max(p["sigma2.irregular"], 1e-30)),
        GM.from_per_sample(DT, phi=phi, sigma2_drive=max(p["sigma2.ar"], 1e-30)),
        RW.from_per_sample(DT, sigma2_rw=max(p["sigma2.level"], 1e-30)),
        RR(0.0),
    ]
    converged = bool(res.mle_retvals.get("converged", False)) if res.mle_retvals else False
    notes = sorted({type(w.message).__name__ for w in caught})
    return comps, elapsed, float(res.llf), converged, notes


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="skip 3.6M samples and statsmodels")
    args = ap.parse_args()
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} (shared; times include it)")
    print(f"truth: {' + '.join(map(str, TRUTH))}, dt = {DT} s")
    print("\n== scaling of this fit (EM 3 iterations + preconditioned L-BFGS, 3 starts, no CIs) ==")
    results = {}
    sizes = (36_000, 360_000) if args.quick else (36_000, 360_000, 3_600_000)
    for n in sizes:
        y = simulate(n)
        fit, sec = our_fit(y)
        results[n] = (y, fit, sec, our_fit.cpu)
        print(f"N = {n:>9,d}: {sec:7.2f} s wall, {our_fit.cpu:7.2f} s CPU ({1e6 * sec / n:6.2f} µs/sample wall)  "
              f"loglik {fit.loglik:.3f}  "
              f"evals {fit.n_eval}  starts {len(fit.starts)}  " + "  ".join(map(str, fit.components)))
    y, fit, sec, cpu = results[360_000]
    fit1, sec1 = our_fit(y, n_starts=1)
    cpu1 = our_fit.cpu
    print(f"N =   360,000, one start: {sec1:.2f} s wall, {cpu1:.2f} s CPU, loglik {fit1.loglik:.3f}")
    t0 = time.perf_counter()
    full = fit_model(y, DT, "WN+GM+RW+RR", options=FitOptions(n_starts=1))
    print(f"N =   360,000, one start + standard errors + record-length advice: {time.perf_counter() - t0:.2f} s "
          f"({full.profile_evaluations} likelihood evaluations for the intervals; "
          + ", ".join(f"{k} {m}" for k, m in sorted(full.ci95_method.items())) + ")")
    if args.quick:
        return
    print("\n== statsmodels UnobservedComponents(level='lldtrend', autoregressive=1).fit() on the same 360k ==")
    comps, sm_sec, sm_llf, sm_conv, notes = statsmodels_fit(y)
    ll_sm = exact_loglik(comps, y)
    print(f"statsmodels: {sm_sec:.2f} s wall, {statsmodels_fit.cpu:.2f} s CPU, converged={sm_conv}, "
          f"warnings={notes}, own llf {sm_llf:.3f}")
    print("  estimates: " + "  ".join(map(str, comps[:3])))
    print(f"exact log-likelihood (same yardstick): this fit {fit.loglik:.3f}, statsmodels {ll_sm:.3f}, "
          f"difference {fit.loglik - ll_sm:+.3f}")
    sm_cpu = statsmodels_fit.cpu
    print(f"speed-up, wall: {sm_sec / sec:.1f}× (3 starts), {sm_sec / sec1:.1f}× (one start); "
          f"CPU: {sm_cpu / cpu:.1f}×, {sm_cpu / cpu1:.1f}×")
    print("\n== goals (360k) ==")
    print(f"time ≤ 2 s: {'met' if sec <= 2 else 'MISSED'} (wall {sec:.2f} s, CPU {cpu:.2f} s; "
          f"one start wall {sec1:.2f} s, CPU {cpu1:.2f} s)")
    print(f"≥ 30× statsmodels: {'met' if sm_sec / sec >= 30 else 'MISSED'} (wall {sm_sec / sec:.1f}×, "
          f"CPU {sm_cpu / cpu:.1f}×)")
    print(f"loglik ≥ statsmodels − 0.5: {'met' if fit.loglik >= ll_sm - 0.5 else 'MISSED'}")
    per = [1e6 * results[n][3] / n for n in sizes]
    print("CPU time per sample [µs] for N = "
          + ", ".join(f"{n:,d}: {p:.2f}" for n, p in zip(sizes, per, strict=True)))


if __name__ == "__main__":
    main()
