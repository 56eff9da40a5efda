"""Where bench_loop_effects' ``lpf2`` case (a second-order low-pass: an OSC of short memory, + WN + RW) ends with a
first-order filter (LPF, MA) beside or instead of that OSC: the BIC, N and N's 95 % interval of the loop's final
model, of that model without each first-order filter, and of the true structure (WN+OSC+RW) fitted from the truth
(docs/loop.md, re-selection: the filter's order). Its committed output ran with the loop before re-selection's
second-order swap (3522ec7), whose final models it shows.

Run:  PYTHONPATH=$PWD nice -n 10 python bench/studies/probe_lpf2_filter_shape.py [--seeds 10]
(prints its findings; a few minutes per record)
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # bench/, for its shared helpers

from bench_loop_effects import DT, K_TRUE, N_TRUE, probe_arguments, simulate

from imu_noise_id.core.estimation.em.relabel import with_uncertainty
from imu_noise_id.core.estimation.readouts import kalibr
from imu_noise_id.core.noise.components import RW, WN
from imu_noise_id.pipelines.loop import run_closed_loop
from imu_noise_id.pipelines.loop.state import Diagnosis
from imu_noise_id.pipelines.loop.steps import AxisLoop, _canonical

FIRST_ORDER = ("LPF", "MA")


def describe(label: str, model: str, diag: Diagnosis, n_true: float) -> str:
    """One line: the model, its BIC and N with its 95 % interval against the truth."""
    n = kalibr.noise_density(with_uncertainty(diag.fit))
    lo, hi = n.ci95
    held = "holds" if lo <= n_true <= hi else "misses"
    return (f"   {label:28s} {model:28s} BIC {diag.errors.bic:10.1f}  N {n.value / n_true - 1:+6.1%} "
            f"(95 % {lo / n_true - 1:+6.1%} … {hi / n_true - 1:+6.1%}: {held})")


def main() -> None:
    args, n = probe_arguments(__doc__)
    print(f"# bench/studies/probe_lpf2_filter_shape.py --seeds {args.seeds} --minutes {args.minutes:g} "
          f"({n} samples at 100 Hz; N as sampled, K = {K_TRUE})", flush=True)
    for s in range(args.seeds):
        t0 = time.perf_counter()
        y, truth = simulate("lpf2", 1000 + s, n)
        r = run_closed_loop(y, DT, "WN+RW", axis="x")
        diag, state = r.final.diagnosis, r.final.state
        osc = truth["second_order"]
        lines = [f"lpf2 seed {1000 + s} (OSC f0 {osc.frequency:.1f} Hz, damping "
                 f"{osc.bandwidth / (2 * osc.frequency):.2f}; steps {', '.join(st.added for st in r.steps[1:])})",
                 describe("loop's final", r.final.model, diag, truth["n"])]
        loop = AxisLoop(y, DT, None, alpha=0.01, lags=20, outliers="impute")
        fitted = list(diag.fit.components)
        # the white noise the filter leaves may be ~0: it starts at the final model's passband density (from ~0 the
        # WN + RW likelihood has a local maximum where a random walk takes everything)
        n_final = kalibr.noise_density(diag.fit).value
        for name in FIRST_ORDER:
            if name in {c.name for c in fitted}:
                rest = [WN(max(c.noise_density, n_final)) if isinstance(c, WN) else c for c in fitted if c.name != name]
                trial = state.with_components(rest)
                lines.append(describe(f"without {name}", trial.name(), loop.diagnose(trial), truth["n"]))
        filtered = osc.sigma * math.sqrt(osc.bandwidth / math.pi) / osc.frequency  # its continuous density
        white = WN(math.sqrt(N_TRUE**2 - filtered**2))
        trial = state.with_components(_canonical([white, osc, RW(K_TRUE)]))
        lines.append(describe("true structure, truth start", trial.name(), loop.diagnose(trial), truth["n"]))
        lines.append(f"   ({time.perf_counter() - t0:.0f} s)")
        print("\n".join(lines), flush=True)


if __name__ == "__main__":
    main()
