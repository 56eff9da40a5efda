"""Closed loop on measured data: the six ADIS16405 static runs and the contaminated MTi-G gyro.

Usage (from the repository root; takes tens of minutes on a shared 2-core machine, run it with nice)::

    PYTHONPATH=$PWD nice -n 10 python bench/loop_measured.py [--runs 1,2,3,4,5,6] [--decimate 20] \
        [--max-steps 5] [--out docs/results/loop_measured.txt] [--figures docs/figures]

The ADIS runs (10⁶ samples at 100 Hz each) are block-averaged by ``--decimate`` (default 20 → 5 Hz, 50 000
samples, which keeps the ≈0.5 Hz disturbance, the warm-up drift and the level shifts but hides most of the
quantisation noise); ``--qn-subset`` runs gyro_x/accel_x of run 1 at the full 100 Hz on its first 2·10⁵
samples to look for quantisation. The MTi-G series (5·10⁵ samples) runs at 100 Hz on its first
``--mtig-samples`` samples. The starting model is WN+RW on every axis (the Kalibr model).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from imu_noise_id.core.axes import AXES
from imu_noise_id.pipelines.loop import block_average, run_closed_loop
from imu_noise_id.report.loop_plots import allan_before_after

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def _line(name: str, r) -> list[str]:
    out = []
    for s in r.steps:
        e = s.errors
        out.append(f"{name:16s} {s.index:2d} {s.model:34s} {e.loglik:13.1f} {e.bic:13.1f} {e.av_misfit:7.3f} "
                   f"{e.ljung_box_p:9.2g} {e.peak_ratio:7.1f}  {s.evidence or ''}")
    fin = r.final.diagnosis
    comps = ", ".join(str(c) for c in fin.fit.components)
    regs = "; ".join(f"{k}: " + ", ".join(f"{p}={v:.4g}" for p, v in d.items()) for k, d in fin.exog_values.items())
    out.append(f"{name:16s}    final: {comps}" + (f" | {regs}" if regs else "")
               + (f" | outliers {r.final.state.flagged.size}" if r.final.state.flagged.size else ""))
    out.append(f"{name:16s}    verdict: {r.verdict}")
    out += [f"{name:16s}    not kept after step {s.index}: {t.model}: {t.reason}"
            for s in r.steps for t in s.trials if not t.accepted]
    out += [f"{name:16s}    unexplained: {f.evidence}" for f in r.remaining]
    return out


def _figure(name: str, r, unit: str, figdir: Path | None) -> None:
    if figdir is None or len(r.steps) < 2:
        return
    allan_before_after(r.steps[0], r.final, unit, f"{name}: {r.steps[0].model} → {r.final.model}",
                       path=figdir / f"loop_{name}.png")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", default="1,2,3,4,5,6")
    ap.add_argument("--axes", default=",".join(AXES))
    ap.add_argument("--decimate", type=int, default=20)
    ap.add_argument("--max-steps", type=int, default=5)
    ap.add_argument("--max-candidates", type=int, default=2)
    ap.add_argument("--mtig-samples", type=int, default=200_000)
    ap.add_argument("--skip-mtig", action="store_true")
    ap.add_argument("--qn-subset", action="store_true")
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--figures", type=Path, default=None)
    args = ap.parse_args(argv)
    if not DATA.is_dir():
        print(f"measured data not found at {DATA}; this bench needs ../shared/data", file=sys.stderr)
        return 2
    if args.figures:
        args.figures.mkdir(parents=True, exist_ok=True)
    lines = [f"# bench/loop_measured.py {' '.join(argv or sys.argv[1:])}",
             f"# {'case':14s} step model {'':28s} loglik {'':7s} BIC {'':5s} AVmis  LB p   peak  evidence"]

    def emit(chunk: list[str]) -> None:
        lines.extend(chunk)
        print("\n".join(chunk), flush=True)

    kw = {"max_steps": args.max_steps, "max_candidates": args.max_candidates}
    if args.qn_subset:
        d = np.load(DATA / "adis16405_static" / "adis16405_run1.npz")
        for axis, col in (("gyro_x", d["gyro"][:200_000, 0]), ("accel_x", d["accel"][:200_000, 0])):
            t0 = time.time()
            r = run_closed_loop(col, 0.01, "WN+RW", axis=axis, **kw)
            emit([*_line(f"r1-100Hz-{axis}", r), f"# {time.time() - t0:.0f} s"])
            _figure(f"adis_r1_100hz_{axis}", r, "rad/s" if axis.startswith("gyro") else "m/s^2", args.figures)
    for run in [int(x) for x in args.runs.split(",") if x]:
        d = np.load(DATA / "adis16405_static" / f"adis16405_run{run}.npz")
        data = np.hstack([d["gyro"], d["accel"]])
        dt = float(1.0 / d["fs_hz"]) * args.decimate
        for axis in [a for a in args.axes.split(",") if a]:
            y = block_average(data[:, AXES.index(axis)], args.decimate)
            t0 = time.time()
            r = run_closed_loop(y, dt, "WN+RW", axis=axis, **kw)
            emit([*_line(f"r{run}-{axis}", r), f"# {time.time() - t0:.0f} s"])
            _figure(f"adis_r{run}_{axis}", r, "rad/s" if axis.startswith("gyro") else "m/s^2", args.figures)
    if not args.skip_mtig:
        d = np.load(DATA / "mtig_gyro_x_contaminated" / "mtig_cont_gyro_x.npz")
        y = np.asarray(d["gyro_x"], dtype=float)[: args.mtig_samples]
        t0 = time.time()
        r = run_closed_loop(y, 1.0 / float(d["fs_hz"]), "WN+RW", axis="gyro_x", **kw)
        emit([*_line("mtig-gyro_x", r), f"# {time.time() - t0:.0f} s"])
        _figure("mtig_gyro_x", r, "rad/s", args.figures)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
