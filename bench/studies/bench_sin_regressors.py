"""Cost of the SIN terms: sinusoidal regressor columns in closed form vs filtered, side by side in one run.

Run:  python bench/studies/bench_sin_regressors.py [--quick]  (the repo keeps its output as a
section of docs/results/studies/likelihood_speed.txt, beside the other likelihood-speed studies).

A SIN term is two regressor columns; the GLS profile inside every likelihood evaluation used to filter each like
the data, so a consumer module's dozen narrow lines made every evaluation about four times dearer
(issue 11). :mod:`imu_noise_id.core.kalman.harmonic` computes a declared sinusoid's steady-state response in closed
form. Three measurements, each with the closed form (``closed``) and with every column filtered (``filtered``:
the declarations removed), in alternation in this one process:

1. one log-likelihood-and-gradient evaluation (what L-BFGS-B calls) for 0–12 lines, WN+RW+GM, at 20 min × 100 Hz
   and 1 h × 200 Hz (median of 7, the two in alternation);
2. the fit of WN+RW with twelve SIN terms on 20 min of WN+RW with twelve lines (1–6 Hz), and its log-likelihood;
3. the closed loop from WN+RW (``run_closed_loop``, default steps) on that record and on 1 h at 200 Hz of the same
   sensor, and its final model.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import statistics
import time

import numpy as np

from imu_noise_id.core.estimation.em import mle
from imu_noise_id.core.estimation.em.model import FitOptions, NoiseModel
from imu_noise_id.core.kalman import harmonic
from imu_noise_id.core.noise.components import RW, WN, simulate_sum
from imu_noise_id.pipelines.loop.run import run_closed_loop

LINES = np.array([1.13, 1.58, 2.07, 2.49, 2.96, 3.31, 3.81, 4.29, 4.63, 5.11, 5.44, 5.87])
TRUTH = [WN(1e-3), RW(3e-5)]


@contextlib.contextmanager
def filtered():
    """Every regressor column filtered: no column is recognised as a sinusoid."""
    original = harmonic.sinusoid_omega
    harmonic.sinusoid_omega = lambda column: math.nan
    try:
        yield
    finally:
        harmonic.sinusoid_omega = original


def sin_cos(freqs: np.ndarray, n: int, dt: float) -> np.ndarray:
    t = dt * np.arange(n)
    return np.column_stack([f(2 * math.pi * fr * t) for fr in freqs for f in (np.sin, np.cos)])


def record(n: int, dt: float, seed: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    y = simulate_sum(TRUTH, n, dt, rng)
    for f in LINES:
        y += 2e-3 * np.sin(2 * math.pi * f * np.arange(n) * dt + rng.uniform(0, 2 * math.pi))
    return y


def evaluation(y: np.ndarray, dt: float, k: int):
    """One log-likelihood + gradient evaluation of WN+RW+GM with k lines, as L-BFGS-B calls it."""
    exog = sin_cos(LINES[:k], y.size, dt) if k else None
    names = [f"{a}{i}" for i in range(k) for a in ("s", "c")] or None
    model = NoiseModel(y, dt, "WN(1e-3)+RW(3e-5)+GM(1.0,1e-3)", exog=exog, exog_names=names)
    comps = model.given
    par, base = mle.Parameterisation.of(comps), model.statespace(comps)
    theta = par.to_theta(comps)
    data = mle.em.DataSums.of(model.y, model.z)
    return lambda: mle.loglik_grad_profile(par, theta, base, model.y, model.z, data=data)


def evaluation_ms(y: np.ndarray, dt: float, k: int) -> tuple[float, float]:
    """Median time [ms] of :func:`evaluation` with the closed form and filtered, 7 of each in alternation."""
    closed = evaluation(y, dt, k)
    with filtered():
        plain = evaluation(y, dt, k)
    times: dict[str, list[float]] = {"closed": [], "filtered": []}
    for _ in range(7):
        for label, run in (("closed", closed), ("filtered", plain)):
            t0 = time.perf_counter()
            run()
            times[label].append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times["closed"]), 1e3 * statistics.median(times["filtered"])


def timed(fn):
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - t0, time.process_time() - c0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="part 1 at 20 min only, no loop")
    args = ap.parse_args()
    print(f"# {os.cpu_count()} CPUs; OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}")
    print("## 1. one log-likelihood + gradient evaluation (WN+RW+GM, k lines = 2k SIN columns), median of 7")
    for minutes, rate in ((20, 100.0), *(() if args.quick else ((60, 200.0),))):
        dt = 1.0 / rate
        y = record(int(minutes * 60 * rate), dt)
        for k in (0, 1, 3, 6, 12):
            closed, plain = evaluation_ms(y, dt, k)
            print(f"   {minutes:3d} min at {rate:3.0f} Hz  k={k:2d}  closed {closed:7.1f} ms  filtered {plain:7.1f} ms"
                  f"  ratio {plain / closed:4.2f}")
    dt, n = 0.01, 120_000
    y = record(n, dt)
    exog, names = sin_cos(LINES, n, dt), [f"{a}{i}" for i in range(LINES.size) for a in ("s", "c")]
    print("## 2. fit of WN+RW + 12 SIN (20 min at 100 Hz, twelve 2e-3 lines on WN 1e-3 + RW 3e-5), no intervals")
    options = FitOptions(uncertainty=False)
    fits = {}
    for label, ctx in (("closed", contextlib.nullcontext), ("filtered", filtered)):
        with ctx():
            fit, wall, cpu = timed(lambda: NoiseModel(y, dt, "WN+RW", exog=exog, exog_names=names).fit(None, options))
        fits[label] = fit
        print(f"   {label:8s} wall {wall:6.1f} s  CPU {cpu:6.1f} s  loglik {fit.loglik:.4f}  "
              f"{', '.join(f'{c.name} {next(iter(c.params().values())):.4g}' for c in fit.components)}")
    print(f"   log-likelihood difference {fits['closed'].loglik - fits['filtered'].loglik:+.2e}")
    if args.quick:
        return
    print("## 3. closed loop from WN+RW (default steps)")
    for minutes, rate in ((20, 100.0), (60, 200.0)):
        dt = 1.0 / rate
        y = record(int(minutes * 60 * rate), dt)
        for label, ctx in (("closed", contextlib.nullcontext), ("filtered", filtered)):
            with ctx():
                result, wall, cpu = timed(lambda: run_closed_loop(y, dt, "WN+RW", axis="gyro_x"))  # noqa: B023
            final = result.final
            print(f"   {minutes:3d} min at {rate:3.0f} Hz  {label:8s} wall {wall:6.1f} s  CPU {cpu:6.1f} s  "
                  f"steps {len(result.steps) - 1}  final {final.model}  BIC {final.errors.bic:.2f}  "
                  f"verdict: {result.verdict}")


if __name__ == "__main__":
    main()
