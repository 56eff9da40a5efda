"""``python -m imu_noise_id.demo --out DIR`` (``make demo``): the package on a simulated IMU with known noise.

The demo is a list of parts (:data:`PARTS`), each a function ``part(context) -> None`` that reads and extends
a shared :class:`DemoContext`; further parts (the online node, the closed loop) append themselves to the list.

Offline part: simulate a static IMU with known white-noise and random-walk densities, write it as a rosbag2
(mcap) bag, run the same analysis as ``imu-noise-id analyze`` on it, and print the truth next to the estimates.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from .core.axes import AXES, GYRO_AXES
from .core.components import RW, WN, Component

#: The simulated IMU (a typical MEMS unit), continuous-time densities in SI units.
GYRO_NOISE_DENSITY = 1.7e-4  # rad/s/√Hz
GYRO_RANDOM_WALK = 2.0e-5  # rad/s²/√Hz
ACCEL_NOISE_DENSITY = 2.0e-3  # m/s²/√Hz
ACCEL_RANDOM_WALK = 3.0e-4  # m/s³/√Hz


def demo_model() -> dict[str, list[Component]]:
    """Per-axis components of the simulated IMU: WN + RW with the constants above."""
    gyro = [WN(GYRO_NOISE_DENSITY), RW(GYRO_RANDOM_WALK)]
    accel = [WN(ACCEL_NOISE_DENSITY), RW(ACCEL_RANDOM_WALK)]
    return {a: list(gyro if a in GYRO_AXES else accel) for a in AXES}


@dataclass
class DemoContext:
    """What the parts share: options, the simulated truth, and every part's results and output paths."""

    out: Path
    duration_s: float
    rate_hz: float
    seed: int
    model: dict[str, list[Component]] = field(default_factory=demo_model)
    bag: Path | None = None
    results: dict[str, object] = field(default_factory=dict)
    outputs: dict[str, Path] = field(default_factory=dict)


def _truth(model: dict[str, list[Component]], axis: str, name: str) -> float:
    comp = next(c for c in model[axis] if c.name == name)
    return float(next(iter(comp.params().values())))


def offline_part(ctx: DemoContext) -> None:
    """Simulate a static bag, analyse it like ``imu-noise-id analyze``, print truth vs estimates."""
    from .bag.reader import read_imu
    from .bag.writer import write_bag
    from .core.simulate import simulate_static_imu
    from .pipelines.analysis import analyze_static
    from .report.outputs import summary_table, write_static_outputs

    print(f"== offline: simulate {ctx.duration_s:g} s of a static IMU at {ctx.rate_hz:g} Hz, then analyze ==")
    t0 = time.perf_counter()
    imu = simulate_static_imu(ctx.model, ctx.rate_hz, ctx.duration_s, seed=ctx.seed)
    bag = ctx.out / "static_imu_bag"
    if bag.exists():
        shutil.rmtree(bag)
    ctx.bag = write_bag(bag, imu, storage="mcap")
    t1 = time.perf_counter()
    print(f"wrote {ctx.bag} ({len(imu)} messages on /imu/data) in {t1 - t0:.1f} s")
    imu = read_imu(ctx.bag)
    result = analyze_static(imu)
    paths = write_static_outputs(result, ctx.out / "analysis", rostopic=imu.topic)
    t2 = time.perf_counter()
    print(f"read, analysed and wrote the results in {t2 - t1:.1f} s\n")
    print(summary_table(result))
    print("\ntruth vs estimate (Allan slopes; white noise at tau = 1 s, random walk at tau = 3 s):")
    print(f"{'axis':8s} {'N true':>10s} {'N est':>10s} {'err':>7s}   {'K true':>10s} {'K est':>10s} {'err':>7s}")
    for axis in AXES:
        s = result.slopes[axis]
        n_true, k_true = _truth(ctx.model, axis, "WN"), _truth(ctx.model, axis, "RW")
        n_est, k_est = s.noise_density.value, s.random_walk.value
        print(
            f"{axis:8s} {n_true:10.3e} {n_est:10.3e} {100 * (n_est / n_true - 1):+6.1f}%   "
            f"{k_true:10.3e} {k_est:10.3e} {100 * (k_est / k_true - 1):+6.1f}%"
        )
    for w in result.warnings:
        print(f"warning: {w}")
    ctx.results["offline"] = result
    ctx.outputs.update({f"analysis/{name}": p for name, p in paths.items()})


#: The demo's parts, run in order.
PARTS: list[Callable[[DemoContext], None]] = [offline_part]


def main(argv: list[str] | None = None) -> int:
    """Run every part of the demo and print where the results are."""
    parser = argparse.ArgumentParser(prog="python -m imu_noise_id.demo", description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("demo_output"), help="output directory (default: demo_output)")
    parser.add_argument("--duration", type=float, default=3600.0, help="simulated seconds (default: 3600)")
    parser.add_argument("--rate", type=float, default=200.0, help="IMU rate in Hz (default: 200)")
    parser.add_argument("--seed", type=int, default=1, help="random seed (default: 1)")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    ctx = DemoContext(out=args.out, duration_s=args.duration, rate_hz=args.rate, seed=args.seed)
    for part in PARTS:
        part(ctx)
    print(f"\nresults in {ctx.out}/:")
    if ctx.bag is not None:
        print(f"  {ctx.bag}  (the simulated bag: try `imu-noise-id analyze {ctx.bag}`)")
    for name in ctx.outputs:
        print(f"  {ctx.out / name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
