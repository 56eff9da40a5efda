"""Whether the evidence rule holds gyro_z outside the band: the closed loop on one ADIS16405 axis with a broad-line
(pooled-periodogram) OSC kept whenever the BIC and do-no-harm rules keep it, its evidence gone or not
(docs/loop.md, "Measured data"). A probe, not the loop's rule.

Run:  PYTHONPATH=$PWD nice -n 10 python bench/probe_pooled_line_group.py RUN AXIS [--samples 100000]
(outputs: docs/results/probe_pooled_line_group_r1_gyro_z.txt and _r2_gyro_z.txt,
663 s and 128 s side by side on a shared 2-core machine)

On run 1 gyro_z the loop keeps one OSC at 21.7 Hz and refuses a second one (BIC −541, RMS AV misfit z 2.0 → 1.5)
because the pooled statistic of the broad line it targeted only falls from 414 to 394 (threshold 336, not halved).
Here that refusal is lifted for broad lines only; the trace is printed as bench/loop_trace.py prints it (steps,
trials, verdict, whether the model's AV lies inside the data's band at every τ, AV per τ, what remains).
"""

from __future__ import annotations

import argparse

from loop_trace import trace

from imu_noise_id.core.axes import AXES
from imu_noise_id.core.diagnostics import detectors as det
from imu_noise_id.pipelines.loop import steps as loop_steps
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
    loop_steps.AxisLoop.evidence_gone = broad_lines_kept_by_bic
    print("\n".join(trace(args.run, args.axis, args.samples, script="bench/probe_pooled_line_group.py")))


if __name__ == "__main__":
    main()
