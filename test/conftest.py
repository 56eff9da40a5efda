"""Shared fixtures. Every test process keeps DDS on loopback and rclpy logs in a temporary folder."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest

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
    env.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="imu_noise_id_ros_log_"))
    return env


@pytest.hookimpl(tryfirst=True)  # before xdist's own hook, which reads the groups into the node ids
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Under pytest-xdist (``make test`` runs two workers), every test that starts rclpy or DDS runs on one worker,
    one at a time, as they did before the suite ran on two: two nodes on loopback at once could share a domain (the
    tests draw their ROS_DOMAIN_ID at random). The tests that read the golden run's outputs share one worker too,
    so the session fixture that makes them runs once."""
    for item in items:
        if item.get_closest_marker("ros") or "ros_env" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.xdist_group("dds"))
        elif "golden_run" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.xdist_group("golden"))


def pytest_configure(config: pytest.Config) -> None:
    """Silence third-party deprecation warnings we cannot fix: lark (imported by rosidl when play/rclpy load message
    definitions) imports the deprecated ``sre_parse`` / ``sre_constants`` modules."""
    config.addinivalue_line("filterwarnings", r"ignore:module 'sre_(parse|constants)' is deprecated:DeprecationWarning")


@pytest.fixture(scope="session")
def golden_run(tmp_path_factory) -> dict[str, Path]:
    """The commands run once on the fixed-seed inputs of ``golden_run.py`` (result files by golden name; the
    analyze output folder is the parent of ``analyze_imu.yaml``)."""
    from golden_run import generate

    return generate(tmp_path_factory.mktemp("golden"))
