"""The online demo: a simulated robot bag played into ``imu_noise_id_node``, watched live, compared with the truth.

``python -m imu_noise_id.demo.online [--out DIR] [--rate X]`` (:func:`run_demo`): 1. simulate a robot that stands,
drives and stands (:func:`~imu_noise_id.core.simulation.robot.simulate_robot`, ``StopAndGo``) into a rosbag2 bag;
2. start the node with ``config/imu_noise_id.yaml``; 3. play the bag and show the monitor view; 4. print the final
estimates next to the truth. DDS stays on 127.0.0.1 (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``).
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ..bag.writer import write_robot_bag
from ..core.axes import AXES
from ..core.cmkf import rotation as rot
from ..core.simulation.robot import RobotRun, RobotSensors, StopAndGo, simulate_robot
from ..resources import NODE_PARAMETERS, packaged_config
from ..ros.launch import node_command, ros_environment, stop

#: The demo robot's truth (also used by the end-to-end tests).
DEMO_TRUTH = {
    "gyro_bias": (0.004, -0.006, 0.003),
    "accel_bias": (0.08, -0.05, 0.06),
    "gyro_noise_density": 1e-3,
    "accel_noise_density": 1e-2,
}


#: The demo robot's sensors: :data:`DEMO_TRUTH`, odometry twist noise 5 mm/s and 5 mrad/s, IMU not rotated.
DEMO_SENSORS = RobotSensors(
    accel_bias=DEMO_TRUTH["accel_bias"], gyro_bias=DEMO_TRUTH["gyro_bias"],
    S_v=DEMO_TRUTH["accel_noise_density"] ** 2, S_g=DEMO_TRUTH["gyro_noise_density"] ** 2,
    velocity_noise_std=0.005, angular_velocity_noise_std=0.005, position_noise_std=0.0, pose_variance=(1e-4, 1e-4),
    imu_rotation_xyzw=rot.IDENTITY, noise_order=("gyro", "accel"),
)


def simulate_demo_run(seed: int = 7, *, stand_before: float = 20.0, drive: float = 25.0, stand_after: float = 20.0,
                      imu_rate: float = 200.0, odom_rate: float = 50.0, substeps: int = 8) -> RobotRun:
    """The demo robot: stand, drive, stand (stamps from 1000 s), with :data:`DEMO_SENSORS`."""
    return simulate_robot(
        stand_before + drive + stand_after, np.random.default_rng(seed), motion=StopAndGo(stand_before, drive),
        sensors=DEMO_SENSORS, imu_rate=imu_rate, odom_rate=odom_rate, t0=1000.0, substeps=substeps,
    )


def summary(state: object) -> str:
    """Final estimates from a monitor state next to :data:`DEMO_TRUTH`."""
    from ..ros.monitor import column

    bias = column(state.noise, "bias")
    std = column(state.noise, "bias_std")
    density = column(state.noise, "noise_density")
    truth_bias = list(DEMO_TRUTH["gyro_bias"]) + list(DEMO_TRUTH["accel_bias"])
    truth_n = [DEMO_TRUTH["gyro_noise_density"]] * 3 + [DEMO_TRUTH["accel_noise_density"]] * 3
    lines = ["", "Final estimates vs the simulation's truth",
             f"{'axis':8} {'bias':>10} {'± 1σ':>9} {'true':>9} {'err/σ':>6}   {'N':>9} {'true N':>9} {'err':>6}"]
    for i, axis in enumerate(AXES):
        z = (bias[i] - truth_bias[i]) / std[i] if std[i] > 0 else math.nan
        rel = density[i] / truth_n[i] - 1.0
        lines.append(f"{axis:8} {bias[i]:10.4g} {std[i]:9.2g} {truth_bias[i]:9.3g} {z:6.1f}   {density[i]:9.3g} "
                     f"{truth_n[i]:9.3g} {rel:6.1%}")
    lines.append("(N: white-noise density from the stationary segments [rad/s/√Hz, m/s²/√Hz])")
    return "\n".join(lines)


def run_demo(out: Path | None = None, rate: float = 2.0, seed: int = 7) -> int:
    """Run the whole demo (see the module docstring); returns 0 when the node produced its outputs."""
    state = watch_demo(out, rate, seed)
    return 0 if state.complete() else 1


def online_part(ctx: object) -> None:
    """The online demo as a part of :data:`imu_noise_id.demo.PARTS`: uses ``ctx.out`` and ``ctx.seed``; the node's
    final ``MonitorState`` goes to ``ctx.results["online"]``, the bag to ``ctx.outputs``."""
    print("\n== online: the node on a simulated robot (stand, drive, stand), watched live ==")
    state = watch_demo(Path(ctx.out) / "online", 2.0, int(ctx.seed))
    ctx.results["online"] = state
    ctx.outputs["online/demo_robot_bag"] = Path(ctx.out) / "online" / "demo_robot_bag"


#: Seconds between the monitor's frames when the demo's output is not a terminal.
LOGGED_FRAME_S = 10.0


def watch_demo(out: Path | None = None, rate: float = 2.0, seed: int = 7) -> object:
    """Steps 1–4 of the module docstring; returns the node's final outputs as a ``MonitorState``."""
    import rclpy

    from ..ros.monitor import Listener, render, watch
    from ..ros.play import load_messages

    work = Path(out) if out else Path(tempfile.mkdtemp(prefix="imu_noise_id_demo_"))
    work.mkdir(parents=True, exist_ok=True)
    bag = work / "demo_robot_bag"
    if bag.exists():
        import shutil

        shutil.rmtree(bag)
    run = simulate_demo_run(seed)
    write_robot_bag(run, bag)
    duration = float(run.imu_t[-1] - run.imu_t[0])
    print(f"simulated robot: stand 20 s, drive 25 s, stand 20 s; IMU 200 Hz, odometry 50 Hz → {bag}")
    env = ros_environment()
    os.environ.update({k: env[k] for k in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_LOG_DIR")})
    node = subprocess.Popen(node_command(packaged_config(NODE_PARAMETERS)), env=env)
    player = None
    rclpy.init()
    try:
        time.sleep(2.0)
        load_messages(bag, None)  # fail early with a clear message if the bag is unreadable
        player = subprocess.Popen([sys.executable, "-m", "imu_noise_id", "play", str(bag), "--rate", str(rate),
                                   "--quiet"], env=env)
        viewer = rclpy.create_node("imu_noise_id_demo_monitor")
        listener = Listener(viewer, "/imu_noise_id_node")
        # into a file or a pipe, a frame every LOGGED_FRAME_S (one a second is 36 frames of the same table)
        watch(viewer, listener, 1.0 if sys.stdout.isatty() else LOGGED_FRAME_S, duration / rate + 3.0)
        player.wait(30)
        print(render(listener.state))
        print(summary(listener.state))
        return listener.state
    finally:
        if player is not None:
            stop(player)
        stop(node)
        if rclpy.ok():
            rclpy.shutdown()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m imu_noise_id.demo.online", description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, help="folder for the demo bag (default: a temporary folder)")
    parser.add_argument("--rate", type=float, default=2.0, help="playback speed factor (default 2: ~35 s)")
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args(argv)
    return run_demo(args.out, args.rate, args.seed)


if __name__ == "__main__":
    sys.exit(main())
