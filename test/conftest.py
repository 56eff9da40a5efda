"""Shared fixtures. Every test process keeps DDS on loopback and rclpy logs in a temporary folder."""

from __future__ import annotations

import fcntl
import json
import os
import tempfile
from pathlib import Path

import pytest
from dds import domain_id

# Set before anything imports rclpy (network rule: DDS traffic only to 127.0.0.1).
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="imu_noise_id_ros_log_"))

REPO_ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO_ROOT.parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``../shared/data`` (third-party measured data); tests using it skip when it is absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip("../shared/data is not present: measured-data tests skipped")
    return SHARED_DATA


@pytest.fixture(scope="session")
def ros_env() -> dict[str, str]:
    """Environment for subprocesses that may use rclpy: the full environment plus the network rule."""
    env = dict(os.environ)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    # this xdist worker's own domain (the tests that start nodes draw theirs, from their worker's share, too)
    env.setdefault("ROS_DOMAIN_ID", str(domain_id(10, 99)))
    env.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="imu_noise_id_ros_log_"))
    return env


def pytest_configure(config: pytest.Config) -> None:
    """Silence third-party deprecation warnings we cannot fix: lark (imported by rosidl when play/rclpy load message
    definitions) imports the deprecated ``sre_parse`` / ``sre_constants`` modules."""
    config.addinivalue_line("filterwarnings", r"ignore:module 'sre_(parse|constants)' is deprecated:DeprecationWarning")


@pytest.fixture(scope="session")
def golden_run(tmp_path_factory) -> dict[str, Path]:
    """The commands run once on the fixed-seed inputs of ``golden_run.py`` (result files by golden name; the
    analyze output folder is the parent of ``analyze_imu.yaml``).

    Once per test run, also under pytest-xdist: the first worker to need it makes it under a lock in the folder the
    workers' temporary folders share, and the others read where it is.
    """
    from golden_run import generate

    shared = tmp_path_factory.getbasetemp()
    shared = shared.parent if os.environ.get("PYTEST_XDIST_WORKER") else shared
    with open(shared / "golden.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        index = shared / "golden" / "outputs.json"
        if not index.exists():
            outputs = generate(shared / "golden")
            index.write_text(json.dumps({name: str(path) for name, path in outputs.items()}))
        return {name: Path(path) for name, path in json.loads(index.read_text()).items()}
