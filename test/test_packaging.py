"""The package builds with colcon (from PyPI) in a fresh workspace and its installed executables run."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
PACKAGE = "imu_noise_id"
PACKAGE_FILES = ("package.xml", "setup.py", "setup.cfg", "resource", PACKAGE)


@pytest.fixture(scope="module")
def built_workspace(tmp_path_factory, ros_env) -> tuple[Path, dict[str, str]]:
    colcon = Path(sys.executable).with_name("colcon")
    if not colcon.exists():
        pytest.skip(f"colcon is not installed next to {sys.executable} (pip install colcon-common-extensions)")
    ws = tmp_path_factory.mktemp("ws")
    src = ws / "src" / PACKAGE
    src.mkdir(parents=True)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    for name in PACKAGE_FILES:
        path = REPO_ROOT / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=ignore)
        elif path.exists():
            shutil.copy2(path, src / name)
    proc = subprocess.run(
        [str(colcon), "build", "--base-paths", "src"],
        cwd=ws,
        env=ros_env,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0, f"colcon build failed:\n{proc.stdout}\n{proc.stderr}"
    prefix = ws / "install" / PACKAGE
    # What `. install/setup.bash` sets for an ament_python package: the install's site-packages first.
    site = prefix / Path(sysconfig.get_path("purelib")).relative_to(sysconfig.get_path("data"))
    env = dict(ros_env)
    env["PYTHONPATH"] = os.pathsep.join([str(site), *filter(None, [ros_env.get("PYTHONPATH", "")])])
    env["AMENT_PREFIX_PATH"] = os.pathsep.join([str(prefix), *filter(None, [ros_env.get("AMENT_PREFIX_PATH", "")])])
    return prefix, env


def test_installed_executables_run_with_help(built_workspace):
    prefix, env = built_workspace
    lib = prefix / "lib" / PACKAGE
    executables = sorted(p for p in lib.iterdir() if p.is_file() and os.access(p, os.X_OK))
    assert "imu-noise-id" in [p.name for p in executables]
    for exe in executables:
        proc = subprocess.run(
            [str(exe), "--help"], cwd=prefix, env=env, capture_output=True, text=True, timeout=60, check=False
        )
        assert proc.returncode == 0, f"{exe.name} --help failed:\n{proc.stderr}"
        assert "usage:" in proc.stdout
    # The built package is the one that runs (not a copy installed elsewhere in the venv).
    proc = subprocess.run(
        [sys.executable, "-c", "import imu_noise_id; print(imu_noise_id.__file__)"],
        cwd=prefix, env=env, capture_output=True, text=True, timeout=60, check=True,
    )  # fmt: skip
    assert proc.stdout.strip().startswith(str(prefix))


def test_resource_files_are_installed(built_workspace):
    prefix, _ = built_workspace
    share = prefix / "share" / PACKAGE
    assert (share / "package.xml").read_text() == (REPO_ROOT / "package.xml").read_text()
    assert (prefix / "share" / "ament_index" / "resource_index" / "packages" / PACKAGE).exists()
    configs = sorted(p.name for p in (REPO_ROOT / PACKAGE / "config").glob("*.yaml"))
    assert configs == ["hypotheses_default.yaml", "imu_noise_id.yaml"]
    assert sorted(p.name for p in (share / "config").glob("*.yaml")) == configs


def test_a_plain_wheel_carries_the_default_config_files(tmp_path):
    """`pip install .` (not editable) must let identify and the node find their YAML files (issue 13)."""
    import zipfile

    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w",
                           str(tmp_path), str(REPO_ROOT)], capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr
    wheel = next(tmp_path.glob(f"{PACKAGE}-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    assert f"{PACKAGE}/config/hypotheses_default.yaml" in names and f"{PACKAGE}/config/imu_noise_id.yaml" in names
    site = tmp_path / "site"
    zipfile.ZipFile(wheel).extractall(site)
    code = ("from imu_noise_id.resources import read_hypotheses_file; data, source = read_hypotheses_file(None); "
            "print(source); assert data")
    run = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(site)},
                         capture_output=True, text=True, timeout=60, check=False)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip().startswith(str(site))
