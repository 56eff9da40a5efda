"""The demo's offline part: a simulated static IMU with known noise, analysed by ``imu-noise-id analyze``."""

from __future__ import annotations

import shutil
import time

from ..core.axes import AXES, GYRO_AXES
from ..core.noise.components import RW, WN, Component
from . import DemoContext

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



def _truth(model: dict[str, list[Component]], axis: str, name: str) -> float:
    comp = next(c for c in model[axis] if c.name == name)
    return float(next(iter(comp.params().values())))


def offline_part(ctx: DemoContext) -> None:
    """Simulate a static bag, run ``imu-noise-id analyze`` on it (Allan, EM model selection, closed loop), print
    the truth next to the Allan-slope and the EM estimates."""
    import yaml

    from ..bag.writer import write_bag
    from ..cli import main as cli_main
    from ..core.simulation.static import simulate_static_imu

    print(f"== offline: simulate {ctx.duration_s:g} s of a static IMU at {ctx.rate_hz:g} Hz, then analyze ==")
    t0 = time.perf_counter()
    model = demo_model()
    imu = simulate_static_imu(model, ctx.rate_hz, ctx.duration_s, seed=ctx.seed)
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
            f"{axis:8s} {_truth(model, axis, 'WN'):10.3e} {kalibr[f'{sensor}_noise_density_xyz'][i]:10.3e} "
            f"{n_em:10.3e}   {_truth(model, axis, 'RW'):10.3e} {kalibr[f'{sensor}_random_walk_xyz'][i]:10.3e} "
            f"{k_em:10.3e}  {models[axis]['model']}"
        )
    ctx.outputs.update({f"analysis/{p.name}": p for p in sorted(out.iterdir())})


