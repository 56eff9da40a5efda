"""Hypothesis-bank benchmark: throughput, the paper 002 section 4 reproduction (L trials), Allan variance vs bank.

    python bench/bench_bank.py --skip-reproduction            # throughput and the Allan-variance comparison
    python bench/bench_bank.py --trials 500 --skip-throughput # the reproduction
    python bench/bench_bank.py --skip-throughput --skip-reproduction --dt-sweep 100   # which Δt did the paper use?
    python bench/bench_bank.py --skip-throughput --skip-reproduction --default-set --real
    python bench/bench_bank.py --skip-throughput --skip-reproduction --fig4 100

``bench/run_all.py`` runs each as one section of docs/results/bench_bank.txt (the first with the default set, the
others with ``--long``).

Writes docs/results/criteria_cases.json (the three cases' ``criteria.json`` documents keyed by case, "1" to "3")
and docs/figures/hypotheses_*.png; the criteria at the recorded times (beside the paper's) it prints, as lines and
as a Markdown table.
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

from imu_noise_id.core.hypotheses import Hypothesis, HypothesisBank, HypothesisSet, ParameterPrior  # noqa: E402
from imu_noise_id.core.hypotheses.axis import AxisIdentifier  # noqa: E402
from imu_noise_id.core.hypotheses.config import hypothesis_set_factory  # noqa: E402
from imu_noise_id.core.hypotheses.criteria import paper_case, run_criteria  # noqa: E402
from imu_noise_id.core.noise.components import GM, RW, WN, simulate_sum  # noqa: E402
from imu_noise_id.report.criteria_json import criteria_document  # noqa: E402
from imu_noise_id.resources import read_hypotheses_file  # noqa: E402

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
        walls, cpus = [], []
        for _ in range(3):  # best of 3: the machine is shared
            bank = HypothesisBank(hset)
            t0, c0 = time.perf_counter(), time.process_time()
            bank.run(y, record_every=every)
            walls.append(time.perf_counter() - t0)
            cpus.append(time.process_time() - c0)
        el, cpu = min(walls), min(cpus)
        print(f"batch run, 2 x 256 filters, {y.size} samples, output every {every:>3} sample(s): "
              f"{y.size / el:,.0f} samples/s wall ({el:.2f} s), {y.size / cpu:,.0f} samples/s of CPU time "
              "(best of 3)")
    bank = HypothesisBank(hset)
    t0 = time.perf_counter()
    for v in y[:3000]:
        bank.step(v)
    print(f"streaming step(), 2 x 256 filters (snapshot every call): {(time.perf_counter() - t0) / 3000 * 1e6:.0f} "
          "µs/step")
    for sensor in ("gyro", "accel"):
        make, warm = hypothesis_set_factory(*read_hypotheses_file(None)[:1], 0.01, sensor)
        ident = AxisIdentifier(make, warm, 0.01)
        noise = 1e-3 * np.random.default_rng(2).standard_normal(6000)
        times = np.empty(noise.size)
        for i, v in enumerate(noise):
            t0 = time.perf_counter()
            ident.step(v)
            times[i] = time.perf_counter() - t0
        steady = times[1000:] * 1e6  # after the warm-up
        block = ident.bank.hset.block
        updates = steady[block - 1::block] if block > 1 else steady
        print(f"streaming AxisIdentifier.step(), default {sensor} set at 100 Hz ({ident.bank.n_filters} filters, "
              f"block {block}): mean {steady.mean():.0f} µs per input sample, {np.median(updates):.0f} µs median "
              f"on the calls that update the bank, max {steady.max():.0f} µs")


def allan_vs_bank(dt: float, duration: float) -> None:
    """The paper's fig. 1b point: at 2000 s the AV of a GM and of a RW with the same short-term AV agree within
    their confidence intervals, while the bank tells them apart on the same records.

    Each GM (τ, σ) of the paper's fig. 1b is paired with the RW whose AV has the same +1 slope level
    (K² = 2σ²/τ, i.e. the same increments over τ ≪ τ_c). The bank uses the case-1 GM grid and a RW range widened
    to [0.01, 0.3] u per sample so that the matched RW lies inside its prior.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from imu_noise_id.core.allan import allan_variance

    n = round(duration / dt)
    rt = math.sqrt(dt)
    base = paper_case(1, dt=dt)
    rw = Hypothesis(("RW",), (ParameterPrior("RW.random_walk", 0.01 / rt, 0.3 / rt, 256, "log"),))
    hset = HypothesisSet((rw, base.hypotheses[1]), dt=dt, bias_sigma=base.bias_sigma)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.8))
    print(f"\nAllan variance vs bank on the same {duration:.0f} s records (case 1 model, dt = {dt} s); each GM of the "
          "paper's fig. 1b with the RW of equal short-term AV (K² = 2σ²/τ):")
    colors = ["tab:blue", "tab:red", "tab:green"]
    for i, (tau_c, sig) in enumerate([(60.0, 0.5), (300.0, 1.0), (1500.0, 1.5)]):
        k = sig * math.sqrt(2.0 / tau_c)
        pair = [(f"GM τ={tau_c / 60:.0f} min σ={sig}", [GM(tau_c, sig)], "GM+bias", "-"),
                (f"RW K={k:.3f} (σ_w={k * rt:.3f})", [RW(k)], "RW+bias", "--")]
        bands = []
        for j, (label, comps, true, ls) in enumerate(pair):
            y = simulate_sum(comps, n, dt, np.random.default_rng(100 + 2 * i + j)) + 0.3
            avr = allan_variance(y, dt, confidence=0.95)
            tau = avr.tau
            bands.append((avr.ci_low[:, 0], avr.ci_high[:, 0]))
            ax1.loglog(tau, avr.variance[:, 0], color=colors[i], ls=ls, label=label)
            ax1.fill_between(tau, avr.ci_low[:, 0], avr.ci_high[:, 0], color=colors[i], alpha=0.12)
            res = HypothesisBank(hset).run(y, record_every=max(1, n // 2000))
            p_true = res.probabilities[:, ["RW", "GM"].index(true[:2])]
            ax2.semilogx(res.t, p_true, color=colors[i], ls=ls, label=label)
            print(f"  {label:<28} bank Pr(true) at {duration:.0f} s: {p_true[-1]:.4f}, "
                  f"decided at {res.decision_time} s")
        (lo1, hi1), (lo2, hi2) = bands
        overlap = (lo1 <= hi2) & (lo2 <= hi1)
        print(f"    their AV 95 % CIs overlap at {overlap.mean():.0%} of the {tau.size} averaging times "
              f"({overlap[tau <= 200].mean():.0%} of those ≤ 200 s)")
    ax1.set_xlabel("averaging time τ [s]")
    ax1.set_ylabel("Allan variance [u²]")
    ax1.set_title("AV (core.allan) with 95 % CIs: GM solid, matched RW dashed", fontsize=9)
    ax1.legend(fontsize=6)
    ax2.set_xlabel("time [s]")
    ax2.set_ylabel("bank: probability of the true hypothesis")
    ax2.set_ylim(-0.02, 1.02)
    ax2.set_title("Bayesian bank on the same records", fontsize=9)
    fig.tight_layout()
    fig.savefig(FIGURES / "hypotheses_allan_vs_bank.png", dpi=80)
    plt.close(fig)


def reproduction(trials: int, dt: float, duration: float, tag: str = "") -> None:
    from imu_noise_id.report.hypotheses_plots import plot_criteria

    results, documents = [], {}
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
        documents[str(case)] = criteria_document(r)
        (RESULTS / f"criteria_cases{tag}.json").write_text(json.dumps(documents))  # after each case: kept if cut
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
    print("\n" + "\n".join(rows))  # the criteria at the recorded times beside the paper's, as a Markdown table
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
              f"{r.rsd_real['WN+RW:WN.noise_density'][-1]:.3f}/{r.rsd_real['WN+GM:WN.noise_density'][-1]:.3f}, calc. "
              f"{r.rsd_calculated['WN+RW:WN.noise_density'][-1]:.3f}/{r.rsd_calculated['WN+GM:WN.noise_density'][-1]:.3f}")


def default_set_examples() -> None:
    """The packaged default set on simulated gyro axes WN(2e-3)+RW(1e-4) at 100 Hz: Pr(WN+RW) vs record length."""
    data, source = read_hypotheses_file(None)
    make, warm = hypothesis_set_factory(data, 0.01, "gyro", source)
    print("\ndefault hypothesis set, simulated gyro WN(2e-3)+RW(1e-4) at 100 Hz, three seeds:")
    for duration in (300, 1500):
        out = []
        for seed in range(3):
            y = simulate_sum([WN(2e-3), RW(1e-4)], duration * 100, 0.01, np.random.default_rng(seed))
            final = AxisIdentifier(make, warm, 0.01).run(y, record_every=100).final
            out.append(f"Pr(WN+RW) {final.probabilities['WN+RW']:.3f} (decision {final.decision})")
        print(f"  {duration:5d} s: " + "; ".join(out))


def real_data() -> None:
    """The default set on measured ADIS16405 run 1 (10 000 s at 100 Hz, static): gyro_x and accel_x."""
    from imu_noise_id.core.axes import ImuSeries
    from imu_noise_id.pipelines.identify import identify

    path = ROOT.parent / "shared" / "data" / "adis16405_static" / "adis16405_run1.npz"
    if not path.is_file():
        print(f"\n{path} is absent: real-data example skipped")
        return
    d = np.load(path)
    series = ImuSeries(t=d["t"], gyro=d["gyro"], accel=d["accel"])
    for refine in (0, 2):
        t0 = time.perf_counter()
        res = identify(series, ["gyro_x", "accel_x"], *read_hypotheses_file(None), refine=refine)
        wall = time.perf_counter() - t0
        print(f"\nADIS16405 run 1 ({len(series)} samples per axis), default set, refine {refine}: {wall:.1f} s for "
              "2 axes")
        for axis, e in res.axes.items():
            f = e.result.final
            probs = ", ".join(f"{k} {v:.3g}" for k, v in f.probabilities.items())
            print(f"  {axis} ({e.passes} passes): {probs}; decision {f.decision} first reached at "
                  f"{e.result.decision_time:.0f} s; warm-up white-noise estimate {e.wn_estimate:.3g}")
            for h, est in f.hypotheses.items():
                theta = ", ".join(f"{k} {v:.3g} (RSD {est.rsd[k]:.2g})" for k, v in est.theta.items())
                print(f"    {h}: {theta}")


def replot() -> None:
    """Redraw the criteria figures from the saved docs/results/criteria_cases.json."""
    from types import SimpleNamespace

    from imu_noise_id.report.hypotheses_plots import plot_criteria

    results = []
    documents = json.loads((RESULTS / "criteria_cases.json").read_text())
    for case in (1, 2, 3):
        d = documents[str(case)]
        r = SimpleNamespace(
            case=str(d["case"]), t=np.array(d["t"]),
            error_probability_real=np.array(d["error_probability"]["real"]),
            error_probability_calculated=np.array(d["error_probability"]["calculated"]),
            rsd_real={k: np.array(v) for k, v in d["rsd"]["real"].items()},
            rsd_calculated={k: np.array(v) for k, v in d["rsd"]["calculated"].items()})
        results.append(r)
        plot_criteria([r], FIGURES / f"hypotheses_case{case}.png", f"paper 002 case {case}, L = {d['trials']}")
    plot_criteria(results, FIGURES / "hypotheses_criteria_all.png",
                  f"paper 002 cases 1–3, L = {d['trials']}, dt = {d['dt']} s")


def fig4(trials: int, dt: float, duration: float) -> None:
    """Paper fig. 4: RSD of τ_m for τ_m ∈ [1, 5], [5, 25], [25, 125] min (GM hypothesis alone, case 1 noise)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    print(f"\npaper fig. 4: RSD of tau for three prior ranges (GM + bias only, sigma_v = 0, {trials} trials, "
          f"dt = {dt} s)")
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.2))
    n = round(duration / dt)
    for (lo, hi), c in zip([(1, 5), (5, 25), (25, 125)], ["tab:red", "tab:green", "tab:blue"], strict=True):
        h = Hypothesis(("GM",), (ParameterPrior("GM.tau", lo * 60.0, hi * 60.0, 32, "log"),
                                 ParameterPrior("GM.sigma", 0.5, 1.5, 32, "log")))
        r = run_criteria(HypothesisSet((h,), dt=dt), duration, trials, seed=4, case=f"tau {lo}-{hi} min")
        rr, rc = r.rsd_real["GM:GM.tau"], r.rsd_calculated["GM:GM.tau"]
        mean = (lo + hi) * 30.0
        ax1.loglog(r.t, rr * mean, color=c, label=f"τ ∈ [{lo}, {hi}] min real")
        ax1.loglog(r.t, rc * mean, color=c, ls="--", label="calc.")
        ax2.semilogx(r.t, rr, color=c, label=f"τ ∈ [{lo}, {hi}] min real")
        ax2.semilogx(r.t, rc, color=c, ls="--", label="calc.")
        picks = [int(np.argmin(np.abs(r.t - x))) for x in (10.0, 100.0, 1000.0, n * dt)]
        print(f"  tau in [{lo:3d}, {hi:3d}] min: RSD real/calc at " + ", ".join(
            f"{r.t[i]:.0f} s {rr[i]:.3f}/{rc[i]:.3f}" for i in picks))
    ax1.set_title("RMS error of τ̂ [s]", fontsize=9)
    ax2.set_title("RSD of τ̂", fontsize=9)
    for ax in (ax1, ax2):
        ax.set_xlabel("time [s]")
        ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(FIGURES / "hypotheses_fig4_tau_ranges.png", dpi=80)
    plt.close(fig)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--trials", type=int, default=500)
    ap.add_argument("--dt", type=float, default=0.1, help="sampling period inferred for paper 002 [s]")
    ap.add_argument("--duration", type=float, default=2000.0)
    ap.add_argument("--skip-reproduction", action="store_true")
    ap.add_argument("--skip-throughput", action="store_true")
    ap.add_argument("--default-set", action="store_true", help="also run the default-set examples")
    ap.add_argument("--real", action="store_true", help="also run the default set on measured ADIS16405 data")
    ap.add_argument("--replot", action="store_true", help="only redraw the criteria figures from the saved JSON")
    ap.add_argument("--fig4", type=int, default=0, metavar="L", help="also run the paper's fig. 4 with L trials")
    ap.add_argument("--tag", default="", help="suffix of the output file names (e.g. _dt1)")
    ap.add_argument("--dt-sweep", type=int, default=0, metavar="L",
                    help="also run the sampling-period sweep with L trials per point")
    args = ap.parse_args()
    RESULTS.mkdir(parents=True, exist_ok=True)
    FIGURES.mkdir(parents=True, exist_ok=True)
    if args.replot:
        replot()
        return 0
    t0 = time.perf_counter()
    if not args.skip_throughput:
        throughput(args.dt)
        allan_vs_bank(args.dt, args.duration)
    if not args.skip_reproduction:
        reproduction(args.trials, args.dt, args.duration, args.tag)
    if args.fig4:
        fig4(args.fig4, args.dt, args.duration)
    if args.default_set:
        default_set_examples()
    if args.real:
        real_data()
    if args.dt_sweep:
        dt_sweep(args.dt_sweep, args.duration)
        wn_grid_effect(args.dt_sweep, args.dt, args.duration)
    print(f"\ntotal wall time {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
