"""The demo's offline part: a simulated static IMU with known noise, analysed by ``imu-noise-id analyze`` with both
estimators (the EM and the GMWM side by side)."""

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
    """Simulate a static bag, run ``imu-noise-id analyze --estimator both`` on it (Allan, GMWM and EM model selection
    compared, closed loop), print the truth next to the Allan-slope, the EM and the GMWM estimates."""
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
    print(f"$ imu-noise-id analyze {ctx.bag} --out {out} --estimator both", flush=True)
    if cli_main(["analyze", str(ctx.bag), "--out", str(out), "--estimator", "both"]) != 0:
        raise SystemExit("demo: analyze failed (see the message above)")
    print(f"read, analysed and wrote the results in {time.perf_counter() - t1:.1f} s\n")
    kalibr = yaml.safe_load((out / "imu.yaml").read_text())
    models = yaml.safe_load((out / "model.yaml").read_text())["axes"]
    print("truth vs estimates: Allan slopes (white noise at tau = 1 s, random walk at tau = 3 s), the EM model "
          "selection, the GMWM fit (wavelet variance) and the final model (imu.yaml's numbers, after the closed loop)")
    print(f"{'axis':8s} {'N true':>10s} {'N Allan':>10s} {'N EM':>10s} {'N GMWM':>10s} {'N final':>10s}   "
          f"{'K true':>10s} {'K Allan':>10s} {'K EM':>10s} {'K GMWM':>10s} {'K final':>10s}  "
          "EM model / GMWM model: agreement")
    for axis in AXES:
        sensor, i = ("gyroscope", AXES.index(axis)) if axis in GYRO_AXES else ("accelerometer", AXES.index(axis) - 3)
        em = {c["type"]: c for c in models[axis]["components"]}
        gm_entry = models[axis].get("gmwm", {})
        gm = {c["type"]: c for c in gm_entry.get("components", [])}
        nan = float("nan")
        agreement = models[axis].get("agreement", {}).get("verdict", "")
        print(
            f"{axis:8s} {_truth(model, axis, 'WN'):10.3e} {kalibr[f'{sensor}_noise_density_allan_xyz'][i]:10.3e} "
            f"{em.get('WN', {}).get('noise_density', nan):10.3e} {gm.get('WN', {}).get('noise_density', nan):10.3e} "
            f"{kalibr[f'{sensor}_noise_density_xyz'][i]:10.3e}   "
            f"{_truth(model, axis, 'RW'):10.3e} {kalibr[f'{sensor}_random_walk_allan_xyz'][i]:10.3e} "
            f"{em.get('RW', {}).get('random_walk', nan):10.3e} {gm.get('RW', {}).get('random_walk', nan):10.3e} "
            f"{kalibr[f'{sensor}_random_walk_xyz'][i]:10.3e}  "
            f"{models[axis]['model']} / {gm_entry.get('model', '-')}: {agreement.split(':')[0]}"
        )
    ctx.outputs.update({f"analysis/{p.name}": p for p in sorted(out.iterdir())})


