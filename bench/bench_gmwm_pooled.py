"""The six ADIS16405 static runs pooled per axis by the GMWM, with the compatibility verdict (issue 14, target 4).

Run:  nice -n 10 python bench/bench_gmwm_pooled.py   (needs ../shared/data; output docs/results/bench_gmwm_pooled.txt)

Per axis: the structure is the WIC winner on run 1 (the EM's candidate set); every run is fitted on its own and the
six together (one θ, :mod:`imu_noise_id.core.estimation.gmwm.pool`), the compatibility statistic
C = J_pooled − Σ J_k with its χ²((K − 1)·p) p-value says whether the runs share one model (5 % level), the pooled
J-test whether the model fits at all. Printed: the pooled parameters with 95 % intervals beside each run's, and the
ratio of the pooled interval's width to the narrowest single-run one (log scale).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from imu_noise_id.core.estimation.gmwm.fit import GmwmOptions, prepare
from imu_noise_id.core.estimation.gmwm.pool import fit_pooled
from imu_noise_id.core.estimation.gmwm.select import select_gmwm
from imu_noise_id.core.noise.modelspec import parameter_labels

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "adis16405_static"
AXES = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")


def _ci(fit, lab: str) -> str:
    lo, hi = fit.ci95[lab]
    return f"[{lo:.3g}, {hi:.3g}]"


def main() -> None:
    if not DATA.is_dir():
        print("../shared/data/adis16405_static absent: skipped")
        return
    t_all = time.perf_counter()
    runs = [np.load(DATA / f"adis16405_run{k}.npz") for k in range(1, 7)]
    dt = 1.0 / float(runs[0]["fs_hz"])
    options = GmwmOptions()
    print(f"# bench_gmwm_pooled.py: 6 runs × {runs[0]['gyro'].shape[0]} samples at {1 / dt:g} Hz per axis; classical "
          "GMWM, scales up to N/8")
    for axis in AXES:
        t0 = time.perf_counter()
        group, col = ("gyro", AXES.index(axis)) if axis.startswith("gyro") else ("accel", AXES.index(axis) - 3)
        wvs = [prepare(r[group][:, col].astype(float), dt, options)[0] for r in runs]
        sel = select_gmwm(None, dt, options=options, wv=wvs[0])
        spec = sel.best.model
        pooled = fit_pooled(wvs, spec, options=options)
        f = pooled.fit
        verdict = "compatible" if pooled.compatible else "NOT compatible"
        print(f"\n== {axis}: {spec} (WIC winner on run 1); compatibility C = {pooled.compatibility:.1f} on "
              f"{pooled.compatibility_dof} dof, p = {pooled.compatibility_p:.3g}: {verdict}; pooled J = "
              f"{pooled.j_statistic:.1f} on {pooled.dof} dof, p = {pooled.p_value:.3g}; "
              f"{time.perf_counter() - t0:.0f} s")
        print("   per-run J-test p: " + ", ".join(f"{r.p_value:.2g}" for r in pooled.runs))
        print("   per-run share of C, J_k(pooled) − J_k(own): " + ", ".join(f"{v:.0f}" for v in pooled.run_rise))
        worst = int(np.argmax(pooled.run_rise))
        rest = fit_pooled([w for k, w in enumerate(wvs) if k != worst], spec, options=options)
        print(f"   without run {worst + 1}: C = {rest.compatibility:.1f} on {rest.compatibility_dof} dof, "
              f"p = {rest.compatibility_p:.3g}: {'compatible' if rest.compatible else 'NOT compatible'}")
        for i, p, lab in parameter_labels(f.components):
            value = f.components[i].params()[p]
            widths = [math.log(r.ci95[lab][1] / r.ci95[lab][0]) for r in pooled.runs
                      if r.ci95[lab][0] > 0 and math.isfinite(r.ci95[lab][1])]
            lo, hi = f.ci95[lab]
            w_pool = math.log(hi / lo) if lo > 0 and math.isfinite(hi) else math.inf
            shrink = f"{w_pool / min(widths):.2f}" if widths and math.isfinite(w_pool) else "n/a"
            print(f"   {lab:>18} pooled {abs(value):.4g} {_ci(f, lab):>24}  width/narrowest run {shrink}")
            print("   " + " " * 18 + " runs   " + "; ".join(
                f"{abs(r.components[i].params()[p]):.3g} {_ci(r, lab)}" for r in pooled.runs))
    print(f"\n# total {time.perf_counter() - t_all:.0f} s")


if __name__ == "__main__":
    main()
