"""The side-by-side benches time the checkout they are given (bench/common.py)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))

from common import check_imports_own_package, run_in_checkout  # noqa: E402


def _copy_of_package(tmp_path: Path) -> Path:
    tree = tmp_path / "other_checkout"
    shutil.copytree(REPO / "imu_noise_id", tree / "imu_noise_id", ignore=shutil.ignore_patterns("__pycache__"))
    return tree


def test_pythonpath_alone_run_from_the_repository_imports_the_repositorys_package(tmp_path):
    """The bug bench_analyze_time had: its baseline ran with PYTHONPATH set to the other checkout but from the
    repository root, and -c/-m put the working directory first, so the 'baseline' was this checkout."""
    tree = _copy_of_package(tmp_path)
    done = subprocess.run([sys.executable, "-c", "import imu_noise_id; print(imu_noise_id.__file__)"],
                          env={"PYTHONPATH": str(tree), "PATH": "/usr/bin:/bin"}, cwd=REPO, capture_output=True,
                          text=True, check=True)
    assert Path(done.stdout.strip()).is_relative_to(REPO / "imu_noise_id")


def test_run_in_checkout_imports_that_checkouts_package_and_refuses_a_tree_without_one(tmp_path):
    tree = _copy_of_package(tmp_path)
    cpu, result = run_in_checkout(tree, "import json\nimport imu_noise_id\nprint(json.dumps(imu_noise_id.__file__))\n",
                                  "the check")
    assert Path(result).is_relative_to(tree) and cpu >= 0.0
    check_imports_own_package(tree, "analyze")
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(SystemExit, match=r"imported|failed"):  # the installed package, or none
        check_imports_own_package(empty, "analyze")
