"""The package builds with colcon (from PyPI) in a fresh workspace and its installed executables run; every install
kind (colcon, a wheel installed by pip into a venv, the editable checkout) finds the one copy of the default YAML
files in config/ (imu_noise_id/resources.py says where it looks)."""

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
PACKAGE_FILES = ("package.xml", "setup.py", "setup.cfg", "resource", "config", PACKAGE)
CONFIGS = ["hypotheses_default.yaml", "imu_noise_id.yaml"]
# Prints where the installed code finds the node's parameters and the default hypothesis set, in this order.
WHERE = ("from imu_noise_id import resources as r; "
         "print(r.packaged_config(r.NODE_PARAMETERS)); print(r.read_hypotheses_file(None)[1])")


def _copy_sources(src: Path) -> None:
    """The files of the package's source tree that a build reads (no build/ or egg-info left by an earlier one)."""
    src.mkdir(parents=True)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    for name in PACKAGE_FILES:
        path = REPO_ROOT / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=ignore)
        elif path.exists():
            shutil.copy2(path, src / name)


def _where(python: str | Path, cwd: Path, env: dict[str, str]) -> list[str]:
    """Where ``python`` (with ``env``) finds the node's parameters and the default hypothesis set."""
    run = subprocess.run([str(python), "-c", WHERE], cwd=cwd, env=env, capture_output=True, text=True, timeout=60,
                         check=False)
    assert run.returncode == 0, run.stderr
    return run.stdout.split()


def _expected(folder: Path) -> list[str]:
    return [str(folder / "imu_noise_id.yaml"), str(folder / "hypotheses_default.yaml")]


@pytest.fixture(scope="module")
def built_workspace(tmp_path_factory, ros_env) -> tuple[Path, dict[str, str]]:
    colcon = Path(sys.executable).with_name("colcon")
    if not colcon.exists():
        pytest.skip(f"colcon is not installed next to {sys.executable} (pip install colcon-common-extensions)")
    ws = tmp_path_factory.mktemp("ws")
    _copy_sources(ws / "src" / PACKAGE)
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
    prefix, env = built_workspace
    share = prefix / "share" / PACKAGE
    assert (share / "package.xml").read_text() == (REPO_ROOT / "package.xml").read_text()
    assert (prefix / "share" / "ament_index" / "resource_index" / "packages" / PACKAGE).exists()
    assert sorted(p.name for p in (REPO_ROOT / "config").glob("*.yaml")) == CONFIGS
    for name in CONFIGS:
        assert (share / "config" / name).read_text() == (REPO_ROOT / "config" / name).read_text()
    # One copy: the YAML files are data files in share/, not package data beside the code.
    site = prefix / Path(sysconfig.get_path("purelib")).relative_to(sysconfig.get_path("data"))
    assert (site / PACKAGE / "resources.py").is_file() and not (site / PACKAGE / "config").exists()
    # The installed code finds them there (through its own prefix, whatever the ament index says).
    assert _where(sys.executable, prefix, env) == _expected(share / "config")


def test_a_wheel_installed_by_pip_finds_the_default_config_files(tmp_path):
    """`pip install .` (not editable) of the wheel, into a new venv: the YAML files are its data files, installed
    into the venv's share/imu_noise_id/config/, where identify and the node find them."""
    import zipfile

    src = tmp_path / "src"
    _copy_sources(src)
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w",
                           str(tmp_path), str(src)], capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr
    wheel = next(tmp_path.glob(f"{PACKAGE}-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    data = next(n.split("/")[0] for n in names if n.endswith(".data/data/share/imu_noise_id/package.xml"))
    assert sorted(n for n in names if n.endswith(".yaml")) == [
        f"{data}/data/share/{PACKAGE}/config/{name}" for name in CONFIGS]
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], timeout=120, check=True)
    python = venv / "bin" / "python"
    # pip asks the new venv's interpreter what it holds: a PYTHONPATH reaching a checkout would show the package as
    # installed already, and pip would install nothing
    clean = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    proc = subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps", "--no-index",
                           "-q", str(wheel)], capture_output=True, text=True, timeout=300, check=False, env=clean)
    assert proc.returncode == 0, proc.stderr
    share = venv / "share" / PACKAGE / "config"
    assert sorted(p.name for p in share.glob("*.yaml")) == CONFIGS
    # The new venv has the package only; PyYAML comes from this venv's site-packages, on PYTHONPATH as a plain
    # folder: its .pth files (the editable install of the checkout among them) are not run.
    env = {**os.environ, "PYTHONPATH": sysconfig.get_path("purelib")}
    env.pop("AMENT_PREFIX_PATH", None)
    run = subprocess.run([str(python), "-c", "import imu_noise_id, sys; print(imu_noise_id.__file__, sys.prefix)"],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=60, check=False)
    assert run.returncode == 0, run.stderr
    where, prefix = run.stdout.split()
    assert Path(where).is_relative_to(venv) and Path(prefix) == venv
    assert _where(python, tmp_path, env) == _expected(share)


def test_the_editable_checkout_finds_config_beside_the_package(tmp_path):
    """`pip install -e .` installs no data files: the checkout's own config/ is the copy used."""
    env = {**os.environ, "PYTHONPATH": str(REPO_ROOT)}
    env.pop("AMENT_PREFIX_PATH", None)
    assert _where(sys.executable, tmp_path, env) == _expected(REPO_ROOT / "config")
    assert not (REPO_ROOT / PACKAGE / "config").exists()


def test_the_search_order_and_the_error_when_no_copy_is_found(tmp_path, monkeypatch):
    """Installed prefix of the code, then sys.prefix, then the ament index; nothing found: a message naming the
    file, the folders and what to do."""
    from imu_noise_id import resources

    site = tmp_path / "prefix" / "lib" / "python3" / "site-packages"
    (site / PACKAGE).mkdir(parents=True)
    monkeypatch.setattr(resources, "PACKAGE_DIR", site / PACKAGE)
    monkeypatch.setattr(sys, "prefix", str(tmp_path / "env"))
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    name = resources.NODE_PARAMETERS
    with pytest.raises(resources.InputError) as info:
        resources.packaged_config(name)
    message = str(info.value)
    assert f"configuration file {name} of {PACKAGE} was not found" in message
    assert str(tmp_path / "prefix" / "share" / PACKAGE / "config") in message
    assert str(tmp_path / "env" / "share" / PACKAGE / "config") in message
    assert "AMENT_PREFIX_PATH is not set" in message and "pip install ." in message and "--params-file" in message

    def put(prefix: Path) -> Path:
        path = prefix / "share" / PACKAGE / "config" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("x: 1\n")
        return path

    ament = tmp_path / "ament"
    (ament / "share" / "ament_index" / "resource_index" / "packages").mkdir(parents=True)
    (ament / "share" / "ament_index" / "resource_index" / "packages" / PACKAGE).touch()
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(ament))
    pytest.importorskip("ament_index_python")
    for prefix in (ament, tmp_path / "env", tmp_path / "prefix"):  # each one found before the ones before it
        path = put(prefix)
        assert resources.packaged_config(name) == path
