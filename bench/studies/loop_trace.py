"""The closed loop's steps and trials on one ADIS16405 axis, with the final model's AV against the data's at every τ:
the trace behind the per-axis explanations in docs/loop.md ("Measured data").

Usage (from the repository root)::

    PYTHONPATH=$PWD python bench/studies/loop_trace.py RUN AXIS [--samples N] [--out FILE]

Prints each step (model, what was added and dropped, BIC, RMS AV misfit z, fitted parameters), every trial with the
reason it was kept or refused, the verdict, the Allan deviations of data and model with the misfit z per τ, and the
detector findings that remain.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # bench/, for its shared helpers
# this checkout's package first: run from another worktree, the editable install would import the main one's
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from common import adis_data_missing, load_adis_run  # bench/common.py

from imu_noise_id.core.axes import AXES
from imu_noise_id.core.diagnostics.residuals import av_misfit_z
from imu_noise_id.pipelines.loop import LoopResult, run_closed_loop
from imu_noise_id.pipelines.loop.rules import av_rms_z


def trace(run: int, axis: str, samples: int, *, script: str = "bench/studies/loop_trace.py") -> list[str]:
    """The loop from WN+RW on ``axis`` of ADIS16405 run ``run`` (its first ``samples``), traced by :func:`describe`
    under a header naming ``script``, the arguments and the time."""
    data, dt = load_adis_run(run, samples)
    start = time.perf_counter()
    r = run_closed_loop(data[:, AXES.index(axis)], dt, "WN+RW", axis=axis)
    return [f"# {script} {run} {axis} --samples {samples}: {time.perf_counter() - start:.0f} s", *describe(r)]


def describe(r: LoopResult) -> list[str]:
    """The lines of a loop's trace: steps with their fitted parameters and trials, verdict, AV per τ, what remains."""
    out = []
    for s in r.steps:
        diag = s.diagnosis
        out.append(f"step {s.index} {s.model} added={s.added} dropped={list(s.dropped)} "
                   f"BIC {diag.errors.bic:.1f} AV z {av_rms_z(diag):.2f}")
        out += [f"    {c.name} " + ", ".join(f"{k} {v:.4g}" for k, v in c.params().items())
                for c in diag.fit.components]
        out += [f"    trial {t.model} {'kept' if t.accepted else 'refused'}: {t.reason}" for t in s.trials]
    diag = r.final.diagnosis
    out.append(f"verdict: {r.verdict}; passed {r.passed}; inside the band {r.av_inside_band}; "
               f"largest relative AV error {r.max_rel_av_error:.2f}" + (f"; {r.note}" if r.note else ""))
    z = av_misfit_z(diag.av_data, diag.av_ci, diag.av_model)
    out += [f"  tau {t:9.2f} s  ADEV data {math.sqrt(a):.3e}  model {math.sqrt(m):.3e}  z {zz:6.2f}"
            for t, a, m, zz in zip(diag.tau, diag.av_data, diag.av_model, z, strict=True)]
    out += [f"  remaining: {f.effect} {f.detector}: {f.evidence}" for f in diag.findings if f.significant]
    return out


def main(argv: list[str] | None = None, *, script: str = "bench/studies/loop_trace.py",
         description: str = __doc__) -> int:
    """The trace of one axis (``script`` and ``description`` name a caller that changed the loop first)."""
    ap = argparse.ArgumentParser(description=description.splitlines()[0])
    ap.add_argument("run", type=int)
    ap.add_argument("axis", choices=AXES)
    ap.add_argument("--samples", type=int, default=100000, help="first N samples (0 = all)")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    if adis_data_missing():
        return 2
    text = "\n".join(trace(args.run, args.axis, args.samples, script=script)) + "\n"
    print(text, end="")
    if args.out is not None:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
