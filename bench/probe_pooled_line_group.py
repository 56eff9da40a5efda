"""Whether the evidence rule holds gyro_z outside the band: the closed loop on one ADIS16405 axis with a broad-line
(pooled-periodogram) OSC kept whenever the BIC and do-no-harm rules keep it, its evidence gone or not
(docs/loop.md, "Measured data"). A probe, not the loop's rule.

Run:  PYTHONPATH=$PWD nice -n 10 python bench/probe_pooled_line_group.py RUN AXIS [--samples 100000]
(outputs: docs/results/probe_pooled_line_group_r1_gyro_z.txt and _r2_gyro_z.txt, 509 s and 80 s on a shared
2-core machine)

On run 1 gyro_z the loop keeps one OSC at 21.7 Hz and refuses a second one (BIC −541, RMS AV misfit z 2.0 → 1.5)
because the pooled statistic of the broad line it targeted only falls from 414 to 394 (threshold 336, not halved).
Here that refusal is lifted for broad lines only; the steps and trials are printed as bench/loop_trace.py does,
with the final verdict, whether the model's AV lies inside the data's band at every τ, and the τ where |z| > 2.
"""

from __future__ import annotations

import argparse
import math
import time

from adis import load_run

from imu_noise_id.core.axes import AXES
from imu_noise_id.core.diagnostics import detectors as det
from imu_noise_id.core.diagnostics.residuals import av_misfit_z
from imu_noise_id.pipelines.loop import run_closed_loop
from imu_noise_id.pipelines.loop import steps as loop_steps
from imu_noise_id.pipelines.loop.run import av_rms_z
from imu_noise_id.pipelines.loop.state import Diagnosis

RULE = loop_steps.AxisLoop.evidence_gone


def broad_lines_kept_by_bic(self: loop_steps.AxisLoop, f: det.Finding, diag: Diagnosis) -> tuple[bool, str]:
    """The loop's evidence rule, but a pooled-periodogram line counts as gone whatever its statistic."""
    gone, why = RULE(self, f, diag)
    return (True, f"{why} (kept by the probe)") if f.detector == "pooled_periodogram" else (gone, why)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=int)
    ap.add_argument("axis", choices=AXES)
    ap.add_argument("--samples", type=int, default=100000)
    args = ap.parse_args()
    data, dt = load_run(args.run, args.samples)
    loop_steps.AxisLoop.evidence_gone = broad_lines_kept_by_bic
    start = time.perf_counter()
    r = run_closed_loop(data[:, AXES.index(args.axis)], dt, "WN+RW", axis=args.axis)
    print(f"# bench/probe_pooled_line_group.py {args.run} {args.axis} --samples {args.samples}: "
          f"{time.perf_counter() - start:.0f} s")
    for s in r.steps:
        print(f"step {s.index} {s.model} added={s.added} dropped={list(s.dropped)} "
              f"BIC {s.diagnosis.errors.bic:.1f} AV z {av_rms_z(s.diagnosis):.2f}")
        for t in s.trials:
            print(f"    trial {t.model} {'kept' if t.accepted else 'refused'}: {t.reason}")
    print(f"verdict: {r.verdict}; inside the band {r.av_inside_band}; largest relative AV error "
          f"{r.max_rel_av_error:.2f}")
    dg = r.final.diagnosis
    z = av_misfit_z(dg.av_data, dg.av_ci, dg.av_model)
    for tau, a, m, zz in zip(dg.tau, dg.av_data, dg.av_model, z, strict=True):
        if abs(zz) > 2.0:
            print(f"  tau {tau:9.2f} s  ADEV data {math.sqrt(a):.3e}  model {math.sqrt(m):.3e}  z {zz:6.2f}")


if __name__ == "__main__":
    main()
