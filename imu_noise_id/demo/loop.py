"""Demo of the closed loop on a simulated bag with effects the starting model does not declare.

``python -m imu_noise_id.demo.loop --out DIR`` (or :func:`run_loop_demo`): the bag of :func:`simulate_demo_bag`,
the loop from ``WN+RW`` on gyro_x (clean) and the four axes with effects. Writes ``DIR/loop_demo_bag/`` and the
analysis's files (``DIR/model.yaml``, ``DIR/report.html``, …).
"""

from __future__ import annotations

import argparse
import math
import shutil
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..core.axes import sensor_of

if TYPE_CHECKING:
    from ..pipelines.analyze.numbers import Reading

DEMO_AXES = ("gyro_x", "gyro_z", "accel_x", "accel_y", "accel_z")
#: What the demo bag holds beyond WN+RW, per axis (the truth the loop's final models are printed against).
INSERTED = {"gyro_x": "", "gyro_z": "GM", "accel_x": "SIN", "accel_y": "OSC", "accel_z": "LPF"}
#: The simulated random walk K per sensor [rad/s²/√Hz, m/s³/√Hz].
SIMULATED_WALK = {"gyro": 2e-5, "accel": 4e-5}


def simulate_demo_bag(path: Path, *, seed: int = 7, duration_s: float = 300.0, rate_hz: float = 100.0) -> Path:
    """Write the demo bag: WN+RW on every axis, plus GM(τ = 2 s) on gyro_z, a 0.5 Hz sine on accel_x, an OSC at
    7 Hz on accel_y, and an LPF (15 Hz) in place of accel_z's white noise."""
    from ..bag.writer import write_bag
    from ..core.noise.components import GM, LPF, OSC, RW, WN
    from ..core.simulation.static import simulate_static_imu

    gyro_k, accel_k = SIMULATED_WALK["gyro"], SIMULATED_WALK["accel"]
    model = {a: [WN(1e-3), RW(gyro_k)] for a in ("gyro_x", "gyro_y", "gyro_z")}
    model |= {a: [WN(2e-3), RW(accel_k)] for a in ("accel_x", "accel_y", "accel_z")}
    model["gyro_z"] = [*model["gyro_z"], GM(tau=2.0, sigma=3e-3)]
    model["accel_y"] = [*model["accel_y"], OSC(frequency=7.0, bandwidth=0.3, sigma=4e-3)]
    model["accel_z"] = [LPF(noise_density=2e-3, cutoff=15.0), RW(accel_k)]
    imu = simulate_static_imu(model, rate_hz, duration_s, seed=seed)
    imu.accel[:, 0] += 6e-3 * np.sin(2 * math.pi * 0.5 * imu.t)
    if path.exists():
        shutil.rmtree(path)
    return write_bag(path, imu)


def _missing_walk(axis: str, walk: Reading | None) -> str:
    """``−RW``, with what ``imu.yaml`` pasted for K instead when ``walk`` (the axis's pasted reading) is given."""
    if walk is None:
        return "−RW"
    truth = SIMULATED_WALK[sensor_of(axis)]
    side = "≥" if walk.value >= truth else "<"
    return f"−RW (K pasted as {walk.method} {walk.value:.2g} {side} the simulated {truth:.2g})"


def truth_table(results: dict, walks: dict[str, Reading] | None = None) -> str:
    """Per demo axis: the simulated model, the loop's final one, whether it holds the inserted effect, what else;
    a walk the final model lacks is shown with the K pasted in its place (``walks``: the pasted readings by axis)."""
    lines = [f"{'axis':8s} {'simulated':14s} {'final model':22s} found  against the truth"]
    for axis, loop in results.items():
        truth = ["WN", *filter(None, [INSERTED[axis]]), "RW"] if axis != "accel_z" else ["LPF", "RW"]
        final = loop.final.model.split("+")
        found = "-" if not INSERTED[axis] else ("yes" if INSERTED[axis] in final else "no")
        extra = [f"+{c}" for c in final if c not in truth]
        extra += [_missing_walk(axis, (walks or {}).get(axis)) if c == "RW" else f"−{c}"
                  for c in truth if c not in final]
        lines.append(f"{axis:8s} {'+'.join(truth):14s} {loop.final.model:22s} {found:5s}  "
                     f"{' '.join(extra) if extra else 'as simulated'}")
    return "\n".join(lines)


def run_loop_demo(out: str | Path, *, seed: int = 7) -> dict:
    """Simulate, write and read the bag, analyse :data:`DEMO_AXES` from ``WN+RW`` with the closed loop (``analyze``
    with the model given, as the ``loop`` command runs it), write its files (model.yaml, report.html, …); returns the
    loops by axis."""
    from ..bag.reader import read_static
    from ..pipelines.analyze import AnalyzeOptions, ModelStage, analyze
    from ..report.analysis import write_analysis
    from ..report.console import loop_table

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    bag = simulate_demo_bag(out / "loop_demo_bag", seed=seed)
    recording = read_static(bag)
    options = AnalyzeOptions(models=ModelStage("WN+RW", estimator="em"), axes=DEMO_AXES)
    result = analyze(recording.imu, recording.temperature, options)
    write_analysis(result, out, meta={"source": str(bag), "command": "loop demo", "model": "WN+RW"},
                   title="closed-loop demo: undeclared GM (gyro_z), 0.5 Hz sine (accel_x), 7 Hz wandering vibration "
                   "(accel_y), 15 Hz low-pass (accel_z)")
    print(loop_table(result.loops))
    pasted = {a.axis: a.random_walk for s in result.numbers.sensors.values() for a in s.axes}
    print(truth_table(result.loops, pasted))
    print(f"demo bag, model.yaml and report.html in {out}/")
    return result.loops


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Closed-loop demo on a simulated bag with undeclared effects.")
    parser.add_argument("--out", type=Path, default=Path("demo_output"), help="output directory")
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args(argv)
    run_loop_demo(args.out, seed=args.seed)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
