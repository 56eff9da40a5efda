"""Probe: the innovation-hump search (``core.diagnostics.lines.detect_innovation_hump``) on ADIS16405 axes fitted
as WN+RW, and whether the joint search's hump trial (``pipelines.loop.trials.hump_resonance``) offers a resonance.

Usage (from the repository root)::

    PYTHONPATH=$PWD python bench/studies/probe_innovation_hump.py [--axes 6:accel_z,3:gyro_z] [--samples N] [--out FILE]

Per axis: the hump's evidence, its centre and half-height width [Hz], and the trial's offer (None where the hump is
not significant or wider than its centre: Q < 1). It prints its findings.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # bench/, for its shared helpers

from common import adis_data_missing, load_adis_run  # bench/common.py

from imu_noise_id.core.axes import AXES
from imu_noise_id.core.diagnostics.lines import detect_innovation_hump
from imu_noise_id.pipelines.loop import LoopState
from imu_noise_id.pipelines.loop.steps import AxisLoop
from imu_noise_id.pipelines.loop.trials import hump_resonance


def probe(run: int, axis: str, samples: int) -> str:
    data, dt = load_adis_run(run, samples)
    loop = AxisLoop(data[:, AXES.index(axis)], dt, None, alpha=0.01, lags=20, outliers="impute")
    diag = loop.diagnose(LoopState(structure=["WN", "RW"]))
    hump = detect_innovation_hump(diag.innovations, dt, alpha=0.01)
    offer = hump_resonance(loop, diag)
    offered = "none" if offer is None else ", ".join(f"{k} {v:.3g}" for k, v in offer.params.items())
    return (f"run{run} {axis} (WN+RW): significant {hump.finding.significant}; {hump.finding.evidence}; "
            f"Q = f0/B = {hump.frequency / hump.bandwidth:.2f}; trial's resonance: {offered}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--axes", default="6:accel_z,3:gyro_z", help="run:axis pairs")
    ap.add_argument("--samples", type=int, default=100000, help="first N samples (0 = all)")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    if adis_data_missing():
        return 2
    lines = [f"# bench/studies/probe_innovation_hump.py --axes {args.axes} --samples {args.samples}"]
    for pair in args.axes.split(","):
        run, axis = pair.split(":")
        lines.append(probe(int(run), axis, args.samples))
        print(lines[-1], flush=True)
    if args.out is not None:
        args.out.write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
