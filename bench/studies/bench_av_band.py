"""Coverage of the loop's AV band when the model is right: the model's exact EDF against the textbook one.

Usage (from the repository root)::

    PYTHONPATH=$PWD python bench/studies/bench_av_band.py [--seeds 40] [--out FILE]

Simulates ``--seeds`` records of 1000 s at 100 Hz of an ADIS16405-like accelerometer model (WN + the 0.565 Hz line
+ a 10.8 Hz vibration), computes the Allan variance at the loop's τ and the misfit z-scores against the true model
with two 95 % bands: the EDF of the model's local power-law slope (NIST SP1065; the loop's band before fbb56c0)
and the model's exact EDF (core/diagnostics/av_band.py). Prints per τ both EDFs, the sd of z (1 if the band is
right) and the share of records outside the pointwise band (0.05), and the time of one model EDF on 10⁵ and
7.2·10⁵ samples.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from imu_noise_id.core.allan import allan_variance, choose_m, identify_alpha
from imu_noise_id.core.diagnostics.av_band import model_av_band, model_av_edf
from imu_noise_id.core.diagnostics.residuals import av_misfit_z
from imu_noise_id.core.noise.components import OSC, WN, simulate_sum, total_allan_variance

DT, N = 0.01, 100_000
MODEL = [WN(4e-4), OSC(frequency=0.565, bandwidth=0.002, sigma=4.8e-3),
         OSC(frequency=10.8, bandwidth=0.55, sigma=8.8e-3)]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=40)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    m = choose_m(N, "allan", m_max=N // 10)
    av_model = total_allan_variance(MODEL, m * DT, DT)
    alpha = identify_alpha(m * DT, av_model[:, None], "allan")
    z_model, z_textbook, edf_textbook = [], [], None
    for seed in range(args.seeds):
        av = allan_variance(simulate_sum(MODEL, N, DT, np.random.default_rng(seed)), DT, m=m, alpha=alpha)
        data = av.variance[:, 0]
        edf_textbook = av.edf[:, 0]
        z_model.append(av_misfit_z(data, model_av_band(data, MODEL, m, N, DT), av_model))
        z_textbook.append(av_misfit_z(data, (av.ci_low[:, 0], av.ci_high[:, 0]), av_model))
    z_model, z_textbook = np.array(z_model), np.array(z_textbook)
    edf = model_av_edf(MODEL, m, N, DT)
    lines = [f"# bench/studies/bench_av_band.py --seeds {args.seeds}: {N} samples at {1 / DT:g} Hz, model "
             + " + ".join(f"{c.name}({', '.join(f'{k} {v:g}' for k, v in c.params().items())})" for c in MODEL),
             "    tau [s]   EDF textbook   EDF model   sd z textbook   sd z model   outside textbook   outside model"]
    for k, t in enumerate(m * DT):
        lines.append(f"  {t:9.2f}   {edf_textbook[k]:12.1f}   {edf[k]:9.1f}   {np.std(z_textbook[:, k]):13.2f}   "
                     f"{np.std(z_model[:, k]):10.2f}   {np.mean(np.abs(z_textbook[:, k]) > 1.96):16.2f}   "
                     f"{np.mean(np.abs(z_model[:, k]) > 1.96):13.2f}")
    lines.append(f"all tau: outside the pointwise band textbook {np.mean(np.abs(z_textbook) > 1.96):.3f}, "
                 f"model {np.mean(np.abs(z_model) > 1.96):.3f} (0.05 if right)")
    for n, dt in ((100_000, 0.01), (720_000, 0.005)):
        mm = choose_m(n, "allan", m_max=n // 10)
        start = time.perf_counter()
        model_av_edf(MODEL, mm, n, dt)
        lines.append(f"one model EDF over {mm.size} tau on {n} samples: {time.perf_counter() - start:.2f} s")
    text = "\n".join(lines)
    print(text)
    if args.out is not None:
        args.out.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
