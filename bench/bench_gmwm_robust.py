"""Robustness of the GMWM to outliers, simulated and on the MTi-G gyro (issue 14, target 3).

Run:  nice -n 10 python bench/bench_gmwm_robust.py [--seeds 10] [--n 200000]
      (output in docs/results/bench_gmwm_robust.txt; part 2 needs ../shared/data)

1. Simulated WN+GM+RW records (``--n`` samples at 100 Hz, seeds 700 + k) with 1 %, 2 % and 5 % additive outliers
   (isolated samples, ±20 white-noise standard deviations, random signs). Each contaminated record is fitted by the
   EM, the classical GMWM and the robust GMWM (defaults: biweight efficiency 0.6 after the spike flags); each
   estimate is checked against the 95 % interval of the *same estimator on the same record without outliers*
   ("inside its clean CI"), and its median ratio to the truth is printed.
2. The MTi-G gyro (500 000 samples at 100 Hz, heavy-tailed by its publishers' design): WIC selection and fit by the
   classical and the robust GMWM on the whole record; the closed loop (EM, start WN+RW) on its first 10⁵ samples, as
   in bench/loop_measured.py, for comparison.
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

from imu_noise_id.core.estimation.em.model import FitOptions, fit_model
from imu_noise_id.core.estimation.gmwm.fit import GmwmOptions, fit_gmwm
from imu_noise_id.core.estimation.gmwm.select import select_gmwm
from imu_noise_id.core.noise.components import GM, RW, WN, simulate_sum
from imu_noise_id.core.noise.modelspec import parameter_labels

DT = 0.01
TRUTH = [WN(1e-3), GM(tau=2.0, sigma=5e-4), RW(6e-5)]
SPEC = "WN+GM+RW"
SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
ROBUST = GmwmOptions(robust=True)


def _fit(name: str, y: np.ndarray):
    if name == "EM":
        return fit_model(y, DT, SPEC, options=FitOptions(n_starts=2))
    return fit_gmwm(y, DT, SPEC, options=ROBUST if name == "robust GMWM" else None)


def simulated(seeds: int, n: int) -> None:
    labels = parameter_labels(TRUTH)
    names = ("EM", "GMWM", "robust GMWM")
    sigma = TRUTH[0].noise_density / math.sqrt(DT)
    print(f"== 1. {SPEC} ({', '.join(str(c) for c in TRUTH)}), {n} samples at {1 / DT:g} Hz, {seeds} seeds; outliers "
          f"±{20 * sigma:.3g} (20 white-noise sd) ==")
    clean: dict[int, dict] = {}
    for rate in (0.01, 0.02, 0.05):
        t0 = time.perf_counter()
        inside = {nm: {lab: 0 for *_, lab in labels} for nm in names}
        ratios = {nm: {lab: [] for *_, lab in labels} for nm in names}
        for k in range(seeds):
            rng = np.random.default_rng(700 + k)
            y = simulate_sum(TRUTH, n, DT, rng)
            if k not in clean:
                clean[k] = {nm: _fit(nm, y) for nm in names}
            dirty = y.copy()
            idx = rng.choice(n, size=int(rate * n), replace=False)
            dirty[idx] += rng.choice([-1.0, 1.0], idx.size) * 20.0 * sigma
            for nm in names:
                fit = _fit(nm, dirty)
                for i, p, lab in labels:
                    value = fit.components[i].params()[p]
                    lo, hi = clean[k][nm].ci95[lab]
                    inside[nm][lab] += lo <= value <= hi
                    ratios[nm][lab].append(value / TRUTH[i].params()[p])
        print(f"-- {100 * rate:g} % outliers ({time.perf_counter() - t0:.0f} s): runs inside the clean record's 95 % "
              "interval of the same estimator / median estimate ÷ truth")
        print(f"  {'parameter':>18} " + " ".join(f"{nm:>24}" for nm in names))
        for *_, lab in labels:
            cells = [f"{inside[nm][lab]:>3}/{seeds}  {np.median(ratios[nm][lab]):9.3g}" for nm in names]
            print(f"  {lab:>18} " + " ".join(f"{c:>24}" for c in cells), flush=True)


def mtig() -> None:
    path = SHARED / "mtig_gyro_x_contaminated" / "mtig_cont_gyro_x.npz"
    if not path.is_file():
        print("\n== 2. MTi-G: ../shared/data absent, skipped ==")
        return
    from imu_noise_id.core.estimation.em.relabel import with_uncertainty
    from imu_noise_id.pipelines.loop import run_closed_loop

    y = np.load(path)["gyro_x"].astype(float)
    print(f"\n== 2. MTi-G gyro x: {y.size} samples at 100 Hz (unit taken as rad/s, see its README) ==")
    for label, options in (("classical GMWM", GmwmOptions()), ("robust GMWM", ROBUST)):
        t0 = time.perf_counter()
        sel = select_gmwm(y, DT, options=options)
        f = sel.best
        print(f"-- {label} ({time.perf_counter() - t0:.0f} s): WIC winner {f.model}, J = {f.j_statistic:.1f} "
              f"(dof {f.dof}, p = {f.p_value:.2g}); misfit τ [s]: "
              f"{', '.join(f'{t:.3g}' for t, z in zip(f.wv.tau, f.residual_z, strict=True) if abs(z) > 2) or 'none'}"
              + (f"; spikes flagged {f.wv.n_replaced}" if f.wv.robust else ""))
        print("   ranking: " + ", ".join(f"{r['model']} ΔWIC {r.get('delta_wic', math.nan):.1f}" for r in sel.table))
        for i, p, lab in parameter_labels(f.components):
            lo, hi = f.ci95[lab]
            print(f"   {lab:>18} {f.components[i].params()[p]:.4g}  [{lo:.4g}, {hi:.4g}]")
    t0 = time.perf_counter()
    loop = run_closed_loop(y[:100_000], DT, "WN+RW")
    fit = with_uncertainty(loop.final.diagnosis.fit)
    print(f"-- closed loop (EM) on the first 10⁵ samples, start WN+RW ({time.perf_counter() - t0:.0f} s): "
          f"{loop.final.model}; {loop.verdict}")
    for i, p, lab in parameter_labels(fit.components):
        lo, hi = fit.ci95.get(lab, (math.nan, math.nan))
        print(f"   {lab:>18} {fit.components[i].params()[p]:.4g}  [{lo:.4g}, {hi:.4g}]")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--n", type=int, default=200_000)
    ap.add_argument("--skip-simulated", action="store_true")
    args = ap.parse_args()
    t0 = time.perf_counter()
    print(f"# bench_gmwm_robust.py --seeds {args.seeds} --n {args.n}")
    if not args.skip_simulated:
        simulated(args.seeds, args.n)
    mtig()
    print(f"# total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
