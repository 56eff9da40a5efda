"""Throughput of imu_noise_id_node: 1 kHz IMU + 100 Hz odometry from another process for 60 s.

    nice -n 10 python bench/bench_node.py [--duration 60] [--executor events] [--watch] \\
        | tee docs/results/bench_node.txt

A simulated robot (stand, drive, stand; 1 kHz IMU, 100 Hz odometry) is written to a bag and played with
``imu-noise-id play`` (its own process) into the node (its own process, ``config/imu_noise_id.yaml``). Printed:
received/sent IMU and odometry messages, the node's per-callback processing time (measured inside the node,
``stats_file`` parameter), and the node's CPU use from /proc/<pid>/stat over the playing time.

``--watch``: the same bag twice, side by side, into the node without and with ``reference:=DIR`` (a results folder of
a static 1 kHz recording of the robot's IMU model, white noise of its densities, analyzed with the model WN), so
that the reference watch's cost (noise-level CUSUMs on every stationary sample, the windowed step and line tests)
is measured against the node without it. Stands of ≥ 30 s (``--duration`` ≥ 90) let the windowed tests run.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from imu_noise_id.bag.writer import write_robot_bag  # noqa: E402
from imu_noise_id.resources import NODE_PARAMETERS, packaged_config  # noqa: E402
from imu_noise_id.ros.launch import ros_environment, stop  # noqa: E402

NODE_CONFIG = packaged_config(NODE_PARAMETERS)


def cpu_seconds(pid: int) -> float:
    """utime + stime of a process [s] from /proc/<pid>/stat."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=float, default=60.0, help="seconds of data played (default 60)")
    parser.add_argument("--executor", default="events", choices=("events", "single_threaded"))
    parser.add_argument("--watch", action="store_true",
                        help="run without and with reference:=DIR, side by side (module docstring)")
    args = parser.parse_args()

    from imu_noise_id.demo.online import simulate_demo_run

    work = Path(tempfile.mkdtemp(prefix="bench_node_"))
    third = args.duration / 3
    run = simulate_demo_run(0, stand_before=third, drive=third, stand_after=third, imu_rate=1000.0, odom_rate=100.0,
                            substeps=2)
    bag = write_robot_bag(run, work / "bag")
    print(f"bench_node: {platform.node()} {platform.machine()}, {os.cpu_count()} cores, executor {args.executor}")
    print(f"played {args.duration:.0f} s: {len(run.imu_t)} IMU messages (1 kHz), {len(run.odom_t)} odometry messages "
          "(100 Hz), from another process (imu-noise-id play)")
    failed = False
    runs = [("", [])]
    if args.watch:
        runs = [("without the reference watch", []), ("with reference:=DIR", ["-p", f"reference:={reference(work)}"])]
    for label, extra in runs:
        if label:
            print(f"\n## {label}")
        failed |= measure(bag, run, work, args.executor, extra)
    return 1 if failed else 0


def reference(work: Path) -> Path:
    """A results folder for the demo robot's IMU at 1 kHz (its white-noise densities; 120 s static, model WN)."""
    from imu_noise_id.core.axes import AXES, GYRO_AXES
    from imu_noise_id.core.noise.components import WN
    from imu_noise_id.core.simulation.static import simulate_static_imu
    from imu_noise_id.demo.online import DEMO_TRUTH
    from imu_noise_id.pipelines.analyze import AnalyzeOptions, ModelStage, analyze
    from imu_noise_id.report.analysis import write_analysis

    model = {a: [WN(DEMO_TRUTH["gyro_noise_density" if a in GYRO_AXES else "accel_noise_density"])] for a in AXES}
    imu = simulate_static_imu(model, 1000.0, 120.0, seed=3)
    out = work / "reference"
    write_analysis(analyze(imu, options=AnalyzeOptions(kinds=("allan",), models=ModelStage("WN"), loop=False, jobs=1)),
                   out, meta={})
    return out


def measure(bag: Path, run, work: Path, executor: str, extra: list[str]) -> bool:
    """Play ``bag`` into a node started with ``extra`` arguments; print the figures; True when the node failed."""
    env = ros_environment()
    stats = work / "stats.json"
    stats.unlink(missing_ok=True)
    node = subprocess.Popen(
        [sys.executable, "-m", "imu_noise_id.ros.node", "--ros-args", "--params-file", str(NODE_CONFIG),
         "-r", "imu:=/imu/data", "-p", f"stats_file:={stats}", "-p", f"executor:={executor}", *extra],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
    )
    time.sleep(3.0)  # import and start-up, not part of the measurement
    cpu0, wall0 = cpu_seconds(node.pid), time.monotonic()
    subprocess.run([sys.executable, "-m", "imu_noise_id", "play", str(bag), "--quiet", "--delay", "10"], env=env,
                   check=True)
    time.sleep(1.0)  # the queue drains
    cpu1, wall1 = cpu_seconds(node.pid), time.monotonic()
    stop(node)
    err = node.stderr.read()
    summary = json.loads(stats.read_text())
    sent_imu, sent_odom = len(run.imu_t), len(run.odom_t)
    print(f"load average {os.getloadavg()[0]:.1f} at the end")
    print(f"received/sent IMU:      {summary['imu_received']}/{sent_imu} = {summary['imu_received'] / sent_imu:.2%}")
    print(f"received/sent odometry: {summary['odom_received']}/{sent_odom} = "
          f"{summary['odom_received'] / sent_odom:.2%}")
    print("per-callback processing time measured inside the node (wall: perf_counter, includes being descheduled "
          "on a loaded machine; CPU: thread_time):")
    for key, label in (("imu", "IMU callback, wall"), ("imu_cpu", "IMU callback, CPU"),
                       ("odom", "odometry callback, wall"), ("publish", "publish timer (bank), wall")):
        s = summary[key]
        if s["count"]:
            print(f"  {label:27s} n={s['count']:6d}  p50 {s['p50_us']:7.1f} us  p99 {s['p99_us']:7.1f} us  "
                  f"p99.9 {s['p99.9_us']:8.1f} us  max {s['max_us']:8.1f} us")
    cpu = (cpu1 - cpu0) / (wall1 - wall0)
    print(f"node CPU: {cpu1 - cpu0:.1f} s over {wall1 - wall0:.1f} s = {cpu:.0%} of one core "
          "(/proc/<pid>/stat utime+stime)")
    goals = [summary["imu_received"] == sent_imu, summary["imu"]["p99_us"] < 1000.0,
             summary["imu_cpu"]["p99_us"] < 1000.0, cpu < 0.5]
    print("goals (100 % received, wall p99 < 1 ms, CPU-time p99 < 1 ms, CPU < 50 %):",
          ", ".join("met" if g else "NOT met" for g in goals))
    if "Traceback" in err:
        print(err)
        return True
    return False


if __name__ == "__main__":
    sys.exit(main())
