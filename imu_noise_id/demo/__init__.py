"""``python -m imu_noise_id.demo --out DIR`` (``make demo``): the package on a simulated IMU with known noise.

Parts (:data:`PARTS`), each ``part(context) -> None`` reading and extending a shared :class:`DemoContext`: offline
(a simulated static bag analysed, truth printed beside the estimates), loop (:mod:`imu_noise_id.demo.loop`) and
online (the node on a simulated robot, :mod:`imu_noise_id.demo.online`).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path


@dataclass
class DemoContext:
    """What the parts share: options, and every part's results and output paths."""

    out: Path
    duration_s: float
    rate_hz: float
    seed: int
    bag: Path | None = None
    results: dict[str, object] = field(default_factory=dict)
    outputs: dict[str, Path] = field(default_factory=dict)


def offline_part(ctx: DemoContext) -> None:
    """Simulate a static bag and analyse it (:mod:`.offline`)."""
    from .offline import offline_part as run_offline

    run_offline(ctx)


def loop_part(ctx: DemoContext) -> None:
    """The closed loop on a bag with effects nobody declared (a GM on gyro_z, a 0.5 Hz vibration on accel_x)."""
    from .loop import run_loop_demo

    print("\n== closed loop: a simulated bag with undeclared effects, starting from WN+RW ==")
    out = ctx.out / "loop"
    ctx.results["loop"] = run_loop_demo(out, seed=ctx.seed)
    ctx.outputs.update({"loop/model.yaml": out / "model.yaml", "loop/report.html": out / "report.html"})


def online_part(ctx: DemoContext) -> None:
    """The node on a simulated robot (stand, drive, stand), watched live (:mod:`imu_noise_id.demo.online`)."""
    from .online import online_part as run_online

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
