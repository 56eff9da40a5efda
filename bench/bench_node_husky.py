"""The measured Husky bag through imu_noise_id_node: what the node reports on a real robot.

    nice -n 10 python bench/bench_node_husky.py [--rate 20] | tee docs/results/bench_node_husky.txt

robot_localization's test1 bag (``../shared/data/husky_robot_localization/husky_test1_ros2``: IMU 30 Hz mounted
rotated, wheel odometry ~10 Hz, 395 s of driving with one 10 s stop) is played with ``imu-noise-id play`` into the
node (shipped YAML plus the IMU mounting rotation); at the end ``imu-noise-id monitor --once`` prints the node's
outputs and diagnostics.
"""

from __future__ import annotations

import argparse
import math
import random
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from imu_noise_id.core.cmkf import rotation as rot  # noqa: E402
from imu_noise_id.resources import NODE_PARAMETERS, packaged_config  # noqa: E402
from imu_noise_id.ros.launch import ros_environment, stop  # noqa: E402

NODE_CONFIG = packaged_config(NODE_PARAMETERS)

BAG = REPO.parent / "shared" / "data" / "husky_robot_localization" / "husky_test1_ros2"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rate", type=float, default=20.0, help="playback speed factor (default 20)")
    args = parser.parse_args()
    if not BAG.is_dir():
        print(f"bench_node_husky: {BAG} is absent (see /work/shared/data README)", file=sys.stderr)
        return 2
    env = {**ros_environment(), "ROS_DOMAIN_ID": str(random.randint(10, 99))}
    q = rot.from_ypr(-math.pi / 2, 0.0, math.pi / 2)  # imu_link in base_link: gravity on +y of the IMU
    node = subprocess.Popen(
        [sys.executable, "-m", "imu_noise_id.ros.node", "--ros-args", "--params-file", str(NODE_CONFIG),
         "-r", "imu:=/imu/data", "-r", "odom:=/husky_velocity_controller/odom",
         "-p", f"cmkf.imu_rotation_xyzw:=[{q[0]},{q[1]},{q[2]},{q[3]}]"],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )
    try:
        start = time.monotonic()
        subprocess.run([sys.executable, "-m", "imu_noise_id", "play", str(BAG), "--rate", str(args.rate), "--quiet",
                        "--delay", "15", "--topic", "/imu/data", "/husky_velocity_controller/odom"],
                       env=env, check=True)
        print(f"played {BAG.name} at {args.rate:g}x in {time.monotonic() - start:.1f} s; the node's view at the end:")
        sys.stdout.flush()
        subprocess.run([sys.executable, "-m", "imu_noise_id", "monitor", "--once", "--timeout", "30"], env=env,
                       check=True)
    finally:
        stop(node)
    log = node.stdout.read()
    warnings = [line for line in log.splitlines() if "WARN" in line or "ERROR" in line]
    print(f"node log: {len(warnings)} warning lines" + (":" if warnings else ""))
    for line in warnings[:20]:
        print("  " + line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
