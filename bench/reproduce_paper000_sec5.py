"""Paper 000 §5 on measured data: two GMs + WN fitted to the ADIS16405 accelerometers (run 1, 1e6 samples at
100 Hz), with the Allan-deviation overlay of the fit and 20 simulations of it (as paper 000 fig. 7).

Run:  nice -n 10 python bench/reproduce_paper000_sec5.py   (output in docs/results/reproduce_paper000.txt and
docs/figures/paper000_sec5_adis_accel.png). The paper used an IMAR-FSAS (tactical grade), this is an industrial
MEMS IMU: the numbers are not comparable, the method is.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from imu_noise_id.core.allan import allan_variance
from imu_noise_id.core.estimation.em.model import FitOptions, fit_model
from imu_noise_id.core.estimation.em.selection import select_model
from imu_noise_id.core.simulation.bands import allan_band
from imu_noise_id.report.plots_model import save_allan_overlay

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "adis16405_static" / "adis16405_run1.npz"
OUT_FIG = Path(__file__).resolve().parents[1] / "docs" / "figures" / "paper000_sec5_adis_accel.png"


def main() -> None:
    if not DATA.exists():
        sys.exit(f"measured data not found: {DATA} (see /work/shared/data/README.md)")
    with np.load(DATA) as d:
        accel, dt = np.asarray(d["accel"], float), 1.0 / float(d["fs_hz"])
    panels = []
    print(f"ADIS16405 run 1: {accel.shape[0]} samples, dt = {dt} s; model WN+2GM (paper 000 §5)")
    for k, axis in enumerate(("accel_x", "accel_y", "accel_z")):
        y = accel[:, k]
        t0 = time.perf_counter()
        fit = fit_model(y, dt, "WN+2GM")
        sec = time.perf_counter() - t0
        print(f"\n{axis}: {sec:.1f} s, loglik {fit.loglik:.1f}, BIC {fit.bic:.1f}, information_ok "
              f"{fit.information_ok}")
        for c in fit.components:
            ps = c.per_sample(dt)
            paper = (f"beta {ps['beta']:.4g} 1/s, sigma2_gm {ps['sigma2_gm']:.3g} (m/s²)²" if c.name == "GM"
                     else f"sigma2_wn {ps['sigma2_wn']:.3g} (m/s²)²")
            print(f"  {c}   [paper units: {paper}]")
        for lab, (lo, hi) in fit.ci95.items():
            print(f"  95 % CI {lab}: [{lo:.4g}, {hi:.4g}]")
        rl = fit.record_length
        for lab, need in rl.needed_s.items():
            print(f"  record for ±10 %: {lab}: {need / 3600:.3g} h (now {rl.current_s / 3600:.3g} h)"
                  f"{'' if rl.reliable[lab] else '  (lower bound: record not ≫ τ)'}")
        av = allan_variance(y, dt)
        band = allan_band(fit.components, fit.dt, y.size, av.tau, n_sim=20, seed=k)
        panels.append({"tau": av.tau, "avar": av.variance[:, 0], "fit": fit, "simulations": band, "unit": "m/s²",
                       "label": f"ADIS16405 {axis}", "title": f"{axis}: WN+2GM"})
    print("\nBIC ranking on accel_y (default candidates + what the AV suggests):")
    sel = select_model(accel[:, 1], dt, options=FitOptions(n_starts=2, uncertainty=False))
    for row in sel.table:
        print("  " + ", ".join(f"{k}={v:.6g}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()))
    save_allan_overlay(OUT_FIG, panels, title="Paper 000 §5 model (WN + 2 GM) on ADIS16405 accelerometers, run 1")
    print(f"\nfigure: {OUT_FIG.relative_to(OUT_FIG.parents[2])}")


if __name__ == "__main__":
    main()
