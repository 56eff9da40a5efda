"""A colcon-built install starts the node from install/imu_noise_id/lib/imu_noise_id/ with its installed YAML."""

from __future__ import annotations

import signal
import subprocess
import time

import pytest
from dds import domain_id
from test_packaging import built_workspace  # noqa: F401 - the colcon workspace fixture of the packaging test

pytestmark = pytest.mark.ros


def test_installed_node_starts_with_the_installed_parameters(built_workspace):  # noqa: F811
    prefix, env = built_workspace
    env = {**env, "ROS_DOMAIN_ID": str(domain_id(10, 99))}
    exe = prefix / "lib" / "imu_noise_id" / "imu_noise_id_node"
    params = prefix / "share" / "imu_noise_id" / "config" / "imu_noise_id.yaml"
    assert exe.is_file() and params.is_file()
    proc = subprocess.Popen([str(exe), "--ros-args", "--params-file", str(params)], cwd=prefix, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        time.sleep(6.0)  # import, parameters, hypothesis set (from the installed share/), subscriptions
        assert proc.poll() is None, proc.stdout.read()
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            out, _ = proc.communicate(timeout=20)
        except subprocess.TimeoutExpired:  # never leave the node running for the tests after this one
            proc.kill()
            out, _ = proc.communicate()
            pytest.fail(f"the node did not stop within 20 s of SIGINT:\n{out}")
    assert proc.returncode == 0, out
    assert "listening on /imu/data, /odom, /imu/temperature" in out
    assert "Traceback" not in out
