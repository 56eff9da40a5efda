"""``python -m imu_noise_id.demo --out DIR`` (``make demo``): the package on a simulated IMU with known noise.

The demo is a set of parts (:data:`PARTS`), each a function ``part(context) -> None`` that reads and extends a
shared :class:`DemoContext`:

* offline: simulate a static IMU with known white-noise and random-walk densities, write it as a rosbag2 (mcap)
  bag, run ``imu-noise-id analyze`` on it (Allan family, EM model selection, closed loop) and print the truth
  next to the Allan-slope and EM estimates;
* loop: the closed loop on a bag holding effects the starting model does not declare
  (:mod:`imu_noise_id.loop_demo`);
* online: the node on a simulated robot that stands, drives and stands, watched live with the monitor view
  (:mod:`imu_noise_id.demo_online`).
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
from .core.noise.components import RW, WN, Component

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
    """Simulate a static bag, run ``imu-noise-id analyze`` on it (Allan, EM model selection, closed loop), print
    the truth next to the Allan-slope and the EM estimates."""
    import yaml

    from .bag.writer import write_bag
    from .cli import main as cli_main
    from .core.simulation.static import simulate_static_imu

    print(f"== offline: simulate {ctx.duration_s:g} s of a static IMU at {ctx.rate_hz:g} Hz, then analyze ==")
    t0 = time.perf_counter()
    imu = simulate_static_imu(ctx.model, ctx.rate_hz, ctx.duration_s, seed=ctx.seed)
    bag = ctx.out / "static_imu_bag"
    if bag.exists():
        shutil.rmtree(bag)
    ctx.bag = write_bag(bag, imu, storage="mcap")
    t1 = time.perf_counter()
    print(f"wrote {ctx.bag} ({len(imu)} messages on /imu/data) in {t1 - t0:.1f} s")
    out = ctx.out / "analysis"
    print(f"$ imu-noise-id analyze {ctx.bag} --out {out}", flush=True)
    if cli_main(["analyze", str(ctx.bag), "--out", str(out)]) != 0:
        raise SystemExit("demo: analyze failed (see the message above)")
    print(f"read, analysed and wrote the results in {time.perf_counter() - t1:.1f} s\n")
    kalibr = yaml.safe_load((out / "imu.yaml").read_text())
    models = yaml.safe_load((out / "model.yaml").read_text())["axes"]
    print("truth vs estimates: Allan slopes (white noise at tau = 1 s, random walk at tau = 3 s) and the EM fit")
    print(f"{'axis':8s} {'N true':>10s} {'N Allan':>10s} {'N EM':>10s}   {'K true':>10s} {'K Allan':>10s} "
          f"{'K EM':>10s}  EM model")
    for axis in AXES:
        sensor, i = ("gyroscope", AXES.index(axis)) if axis in GYRO_AXES else ("accelerometer", AXES.index(axis) - 3)
        fitted = {c["type"]: c for c in models[axis]["components"]}
        n_em = fitted.get("WN", {}).get("noise_density", float("nan"))
        k_em = fitted.get("RW", {}).get("random_walk", float("nan"))
        print(
            f"{axis:8s} {_truth(ctx.model, axis, 'WN'):10.3e} {kalibr[f'{sensor}_noise_density_xyz'][i]:10.3e} "
            f"{n_em:10.3e}   {_truth(ctx.model, axis, 'RW'):10.3e} {kalibr[f'{sensor}_random_walk_xyz'][i]:10.3e} "
            f"{k_em:10.3e}  {models[axis]['model']}"
        )
    ctx.outputs.update({f"analysis/{p.name}": p for p in sorted(out.iterdir())})


def loop_part(ctx: DemoContext) -> None:
    """The closed loop on a bag with effects nobody declared (a GM on gyro_z, a 0.5 Hz vibration on accel_x)."""
    from .loop_demo import run_loop_demo

    print("\n== closed loop: a simulated bag with undeclared effects, starting from WN+RW ==")
    out = ctx.out / "loop"
    ctx.results["loop"] = run_loop_demo(out, seed=ctx.seed)
    ctx.outputs.update({"loop/model.yaml": out / "model.yaml", "loop/report.html": out / "report.html"})


def online_part(ctx: DemoContext) -> None:
    """The node on a simulated robot (stand, drive, stand), watched live (:mod:`imu_noise_id.demo_online`)."""
    from .demo_online import online_part as run_online

    run_online(ctx)


#: The demo's parts by name, run in this order.
PARTS: dict[str, Callable[[DemoContext], None]] = {
    "offline": offline_part, "loop": loop_part, "online": online_part,
}


def main(argv: list[str] | None = None) -> int:
    """Run every part of the demo and print where the results are."""
    parser = argparse.ArgumentParser(prog="python -m imu_noise_id.demo", description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("demo_output"), help="output directory (default: demo_output)")
    parser.add_argument("--duration", type=float, default=1800.0, help="simulated static seconds (default: 1800)")
    parser.add_argument("--rate", type=float, default=200.0, help="IMU rate in Hz (default: 200)")
    parser.add_argument("--seed", type=int, default=1, help="random seed (default: 1)")
    parser.add_argument("--parts", nargs="+", choices=tuple(PARTS), default=list(PARTS),
                        help="which parts to run (default: all, in this order)")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    ctx = DemoContext(out=args.out, duration_s=args.duration, rate_hz=args.rate, seed=args.seed)
    for name in args.parts:
        PARTS[name](ctx)
    print(f"\nresults in {ctx.out}/:")
    if ctx.bag is not None:
        print(f"  {ctx.bag}  (the simulated bag: try `imu-noise-id analyze {ctx.bag}`)")
    for name in ctx.outputs:
        print(f"  {ctx.out / name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
