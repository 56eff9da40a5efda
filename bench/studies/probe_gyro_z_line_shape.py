"""Probe: where does the loop's final model of an ADIS16405 gyro_z miss the data's spectrum? The data's power
spectral density over the model's, in 2 Hz bands, and the innovations' autocorrelation at the first lags.

Usage (from the repository root)::

    PYTHONPATH=$PWD python bench/studies/probe_gyro_z_line_shape.py [--runs 2,3,4,5] [--axis gyro_z] [--samples N] \
        [--out FILE]

Written for gyro_z of runs 2–5, whose final AV leaves the data's band at τ = 0.03–0.04 s (the model's ADEV ≈ 2 %
above the data's): the loop from WN+RW (``bench/studies/loop_trace.py``), then Welch's PSD of the record (2000-sample
Hann segments, linear detrend; two-sided, as the components' ``psd``) over the sum of the final components' PSDs,
band by band from 2 Hz (the bias processes' band below is left out) to Nyquist.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # bench/, for its shared helpers

import numpy as np
from common import adis_data_missing, load_adis_run  # bench/common.py
from scipy import signal

from imu_noise_id.core.axes import AXES
from imu_noise_id.core.diagnostics.residuals import acf
from imu_noise_id.pipelines.loop import run_closed_loop

#: Width [Hz] of the bands the two spectra are averaged over.
BAND_HZ = 2.0
#: Welch segment length [samples] (0.05 Hz resolution at 100 Hz).
SEGMENT = 2000
#: Innovation autocorrelation lags printed.
LAGS = 8


def probe(run: int, axis: str, samples: int) -> list[str]:
    """The final model of ``axis`` of run ``run`` and its spectral misfit (module docstring)."""
    data, dt = load_adis_run(run, samples)
    y = data[:, AXES.index(axis)]
    last = run_closed_loop(y, dt, "WN+RW", axis=axis).final
    final = last.diagnosis
    f, p = signal.welch(y, fs=1.0 / dt, nperseg=SEGMENT, detrend="linear")
    f, p = f[1:], 0.5 * p[1:]  # two-sided
    model = np.sum([c.psd(f, dt) for c in final.fit.components], axis=0)
    out = [f"run{run} {axis}: {last.model}; " + "; ".join(
        f"{c.name} " + ", ".join(f"{k} {v:.4g}" for k, v in c.params().items()) for c in final.fit.components)]
    for lo in np.arange(BAND_HZ, 0.5 / dt, BAND_HZ):
        band = (f >= lo) & (f < lo + BAND_HZ)
        out.append(f"  {lo:4.0f}–{lo + BAND_HZ:<4.0f} Hz  data/model PSD {p[band].mean() / model[band].mean():.3f}")
    rho = acf(final.innovations, LAGS)
    out.append("  innovation autocorrelation, lags 1–{}: {}  (±{:.3f} at 2 sd)".format(
        LAGS, " ".join(f"{a:+.3f}" for a in rho), 2.0 / np.sqrt(np.isfinite(final.innovations).sum())))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", default="2,3,4,5")
    ap.add_argument("--axis", choices=AXES, default="gyro_z")
    ap.add_argument("--samples", type=int, default=100000, help="first N samples (0 = all)")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    if adis_data_missing():
        return 2
    lines = [f"# bench/studies/probe_gyro_z_line_shape.py --runs {args.runs} --axis {args.axis} "
             f"--samples {args.samples}"]
    print(lines[0], flush=True)
    for run in (int(r) for r in args.runs.split(",")):
        found = probe(run, args.axis, args.samples)
        print("\n".join(found), flush=True)
        lines += found
    if args.out is not None:
        args.out.write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
