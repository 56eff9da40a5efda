"""Launch-free recipe for running the node (ROS 2 from PyPI has no ``launch`` package): its environment (DDS on
127.0.0.1, ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, rclpy logs in a temporary folder), its command line
(``python -m imu_noise_id.ros.node --ros-args …``), stopping it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path


def ros_environment() -> dict[str, str]:
    """This process's environment plus the network rule and a log folder (children inherit all of it)."""
    env = dict(os.environ)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="imu_noise_id_ros_log_"))
    return env


def node_command(params_file: Path, *extra: str) -> list[str]:
    """The command line that starts the node with ``params_file`` (plus extra ``--ros-args`` items, e.g. remaps)."""
    return [sys.executable, "-m", "imu_noise_id.ros.node", "--ros-args", "--params-file", str(params_file), *extra]


def stop(process: subprocess.Popen, timeout: float = 10.0) -> None:
    """Ctrl-C a child process, then kill it if it does not end."""
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
