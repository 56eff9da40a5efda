"""Hypothesis-bank benchmark: throughput, the paper 002 section 4 reproduction (L trials), Allan variance vs bank.

    PYTHONPATH=. nice -n 10 python bench/bench_bank.py --trials 500 | tee docs/results/bench_bank.txt
    PYTHONPATH=. nice -n 10 python bench/bench_bank.py --skip-throughput --skip-reproduction --dt-sweep 100 \
        | tee docs/results/bench_bank_dt_sweep.txt   # which Δt did the paper use? (docs/hypotheses.md)

Writes docs/results/criteria_case{1,2,3}.json, docs/results/criteria_table.md and docs/figures/hypotheses_*.png.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from imu_noise_id.cli.criteria import criteria_document  # noqa: E402
from imu_noise_id.core.components import GM, RW, simulate_sum  # noqa: E402
from imu_noise_id.core.hypotheses import Hypothesis, HypothesisBank, HypothesisSet, ParameterPrior  # noqa: E402
from imu_noise_id.core.hypotheses.criteria import paper_case, run_criteria  # noqa: E402
from imu_noise_id.pipelines.hypotheses_config import load_hypothesis_set  # noqa: E402

RESULTS = ROOT / "docs" / "results"
FIGURES = ROOT / "docs" / "figures"
PAPER = {1: "≈ 0 after a couple of samples", 2: "≈ 2 % at 2000 s", 3: "≈ 10 % at 2000 s"}


def throughput(dt: float) -> None:
    """Batch samples/s and streaming µs/step of a 2 × 256 bank."""
    import os

    print(f"machine load average (1, 5, 15 min) before timing: {os.getloadavg()} on {os.cpu_count()} cores")
    rt = math.sqrt(dt)
    wn = ParameterPrior("WN.noise_density", 0.5 * rt, 0.5 * rt, 1)
    h1 = Hypothesis(("RW", "WN"), (ParameterPrior("RW.random_walk", 0.04 / rt, 0.15 / rt, 256, "log"), wn))
    h2 = Hypothesis(("GM", "WN"), (ParameterPrior("GM.tau", 60, 1500, 16, "log"),
                                   ParameterPrior("GM.sigma", 0.5, 1.5, 16, "log"), wn))
    hset = HypothesisSet((h1, h2), dt=dt)
    y = simulate_sum([GM(300.0, 1.0)], 40_000, dt, np.random.default_rng(0)) + 0.5 * np.random.default_rng(
        1).standard_normal(40_000)
    for every in (1, 100):
        bank = HypothesisBank(hset)
        t0 = time.perf_counter()
        bank.run(y, record_every=every)
        el = time.perf_counter() - t0
        print(f"batch run, 2 x 256 filters, {y.size} samples, output every {every:>3} sample(s): "
              f"{y.size / el:,.0f} samples/s ({el:.2f} s)")
    bank = HypothesisBank(hset)
    t0 = time.perf_counter()
    for v in y[:3000]:
        bank.step(v)
    print(f"streaming step(), 2 x 256 filters (snapshot every call): {(time.perf_counter() - t0) / 3000 * 1e6:.0f} "
          "µs/step")
    for sensor in ("gyro", "accel"):
        dset, _ = load_hypothesis_set(None, 0.01, sensor)
        bank = HypothesisBank(dset)
        noise = 1e-3 * np.random.default_rng(2).standard_normal(5000)
        t0 = time.perf_counter()
        for v in noise:
            bank.step(v)
        print(f"streaming step(), default {sensor} set at 100 Hz ({bank.n_filters} filters, block "
              f"{dset.block}): {(time.perf_counter() - t0) / noise.size * 1e6:.0f} µs/input sample on average")


def allan_vs_bank(dt: float, duration: float) -> None:
    """The paper's fig. 1b point: AV of RW and GM realisations overlap at 2000 s; the bank tells them apart."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rt = math.sqrt(dt)
    cases = [("RW σ_w=0.04", [RW(0.04 / rt)], "RW"), ("RW σ_w=0.15", [RW(0.15 / rt)], "RW"),
             ("GM τ=1 min σ=0.5", [GM(60.0, 0.5)], "GM"), ("GM τ=5 min σ=1", [GM(300.0, 1.0)], "GM"),
             ("GM τ=25 min σ=1.5", [GM(1500.0, 1.5)], "GM")]
    from imu_noise_id.core.allan import allan_variance

    n = round(duration / dt)
    hset = paper_case(1, dt=dt)
    bands = {}
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.6))
    print(f"\nAllan variance vs bank on the same {duration:.0f} s records (case 1, dt = {dt} s):")
    for i, (label, comps, true) in enumerate(cases):
        y = simulate_sum(comps, n, dt, np.random.default_rng(100 + i))
        avr = allan_variance(y, dt, confidence=0.95)
        tau, av, lo, hi = avr.tau, avr.variance[:, 0], avr.ci_low[:, 0], avr.ci_high[:, 0]
        bands[label] = (lo, hi)
        line = ax1.loglog(tau, av, label=label)[0]
        ax1.fill_between(tau, lo, hi, color=line.get_color(), alpha=0.15)
        res = HypothesisBank(hset).run(y, record_every=max(1, n // 2000))
        ax2.semilogx(res.t, res.probabilities[:, hset.names.index(true)], color=line.get_color(), label=label)
        slope = np.polyfit(np.log(tau[-8:]), np.log(av[-8:]), 1)[0]
        print(f"  {label:<20} AV log-log slope over the last 8 tau (up to {tau[-1]:.0f} s): {slope:+.2f};"
              f" bank Pr(true = {true}) at {duration:.0f} s: {res.probabilities[-1, hset.names.index(true)]:.4f},"
              f" decided at {res.decision_time} s")
    print("  fraction of averaging times τ at which the 95 % CIs of two records overlap (RW vs GM):")
    for rw in [c[0] for c in cases if c[2] == "RW"]:
        for gm in [c[0] for c in cases if c[2] == "GM"]:
            (lo1, hi1), (lo2, hi2) = bands[rw], bands[gm]
            ok = np.mean((lo1 <= hi2) & (lo2 <= hi1))
            above = tau >= 10.0
            ok10 = np.mean(((lo1 <= hi2) & (lo2 <= hi1))[above])
            print(f"    {rw:<14} vs {gm:<20}: all τ {ok:.2f}, τ ≥ 10 s {ok10:.2f}")
    ax1.set_xlabel("averaging time τ [s]")
    ax1.set_ylabel("Allan variance [u²]")
    ax1.set_title("overlapping AV (core.allan) with 95 % χ² CIs", fontsize=9)
    ax1.legend(fontsize=7)
    ax2.set_xlabel("time [s]")
    ax2.set_ylabel("bank: probability of the true hypothesis")
    ax2.set_ylim(-0.02, 1.02)
    ax2.set_title("Bayesian bank on the same records", fontsize=9)
    fig.tight_layout()
    fig.savefig(FIGURES / "hypotheses_allan_vs_bank.png", dpi=80)
    plt.close(fig)


def reproduction(trials: int, dt: float, duration: float, tag: str = "") -> None:
    from imu_noise_id.report.hypotheses_plots import plot_criteria

    results = []
    rows = ["| case | paper | t [s] | error real (eq. 15) | error calc. (eq. 18) | decided (≥ γ) | "
            + "RSD real / calc. (eqs. 17, 19, 20) |", "|---|---|---|---|---|---|---|"]
    for case in (1, 2, 3):
        hset = paper_case(case, dt=dt)
        t0 = time.perf_counter()
        r = run_criteria(hset, duration, trials, seed=case, case=str(case))
        wall = time.perf_counter() - t0
        results.append(r)
        print(f"\ncase {case}: {trials} trials, {r.settings['n_filters']} filters, dt {dt} s, {duration:.0f} s: "
              f"wall time {wall:.1f} s")
        (RESULTS / f"criteria_case{case}{tag}.json").write_text(json.dumps(criteria_document(r)))
        plot_criteria([r], FIGURES / f"hypotheses_case{case}{tag}.png", f"paper 002 case {case}, L = {trials}")
        shown = sorted({int(np.argmin(np.abs(r.t - x))) for x in (dt, 3 * dt, 10.0, 100.0, 1000.0, duration)})
        for i in shown:
            target = r.t[i]
            rsd = ", ".join(f"{k.split(':')[1]}({k.split('+')[0] if '+' in k else k.split(':')[0]}) "
                            f"{r.rsd_real[k][i]:.3f}/{r.rsd_calculated[k][i]:.3f}" for k in r.rsd_real)
            print(f"  t = {r.t[i]:7.1f} s: error real {r.error_probability_real[i]:.3f}, calculated "
                  f"{r.error_probability_calculated[i]:.3f} (1 - Pr(true) {r.error_probability_calculated_true[i]:.3f})"
                  f", decided {r.decided[i]:.3f} (wrong {r.decided_wrong[i]:.3f}); RSD real/calc {rsd}")
            rows.append(f"| {case} | {PAPER[case] if target == duration else ''} | {r.t[i]:.1f} | "
                        f"{r.error_probability_real[i]:.3f} | {r.error_probability_calculated[i]:.3f} | "
                        f"{r.decided[i]:.3f} | {rsd} |")
    (RESULTS / f"criteria_table{tag}.md").write_text("\n".join(rows) + "\n")
    plot_criteria(results, FIGURES / f"hypotheses_criteria_all{tag}.png",
                  f"paper 002 cases 1–3, L = {trials}, dt = {dt} s")


def dt_sweep(trials: int, duration: float) -> None:
    """Identification error at the end of the record vs the (unstated) sampling period of paper 002."""
    print(f"\nsampling-period sweep ({trials} trials per point, {duration:.0f} s): identification error real/calc. "
          "at the end, and for case 1 after 3 samples")
    for dt in (0.1, 0.2, 0.5, 1.0):
        parts = []
        for case in (1, 2, 3):
            n = round(duration / dt)
            r = run_criteria(paper_case(case, dt=dt), duration, trials, seed=10 + case, record=[3, n], case=str(case))
            early = f" (after 3 samples {r.error_probability_real[0]:.3f})" if case == 1 else ""
            parts.append(f"case {case} {r.error_probability_real[-1]:.3f}/{r.error_probability_calculated[-1]:.3f}"
                         + early)
        print(f"  dt = {dt:4.2f} s: " + "; ".join(parts))


def wn_grid_effect(trials: int, dt: float, duration: float) -> None:
    """Case 3 with coarser σ_v grids: how much of the identification error a coarse grid adds."""
    print(f"\ncase 3 vs the size of the σ_v grid ({trials} trials, dt = {dt} s, {duration:.0f} s):")
    for n_v in (3, 6):
        r = run_criteria(paper_case(3, dt=dt, grid={"noise_density": n_v}), duration, trials, seed=33,
                         record=[round(duration / dt)], case="3")
        print(f"  σ_v grid {n_v:2d} cells: identification error real {r.error_probability_real[-1]:.3f}, calculated "
              f"{r.error_probability_calculated[-1]:.3f}; RSD σ_v (RW/GM) real "
              f"{r.rsd_real['RW+WN:WN.noise_density'][-1]:.3f}/{r.rsd_real['GM+WN:WN.noise_density'][-1]:.3f}, calc. "
              f"{r.rsd_calculated['RW+WN:WN.noise_density'][-1]:.3f}/{r.rsd_calculated['GM+WN:WN.noise_density'][-1]:.3f}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--trials", type=int, default=500)
    ap.add_argument("--dt", type=float, default=0.1, help="sampling period inferred for paper 002 [s]")
    ap.add_argument("--duration", type=float, default=2000.0)
    ap.add_argument("--skip-reproduction", action="store_true")
    ap.add_argument("--skip-throughput", action="store_true")
    ap.add_argument("--tag", default="", help="suffix of the output file names (e.g. _dt1)")
    ap.add_argument("--dt-sweep", type=int, default=0, metavar="L",
                    help="also run the sampling-period sweep with L trials per point")
    args = ap.parse_args()
    RESULTS.mkdir(parents=True, exist_ok=True)
    FIGURES.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    if not args.skip_throughput:
        throughput(args.dt)
        allan_vs_bank(args.dt, args.duration)
    if not args.skip_reproduction:
        reproduction(args.trials, args.dt, args.duration, args.tag)
    if args.dt_sweep:
        dt_sweep(args.dt_sweep, args.duration)
        wn_grid_effect(args.dt_sweep, args.dt, args.duration)
    print(f"\ntotal wall time {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
