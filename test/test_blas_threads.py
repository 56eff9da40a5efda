"""The command line runs one BLAS thread per process, in itself and in the worker processes it spawns (``analyze
--jobs``): read by threadpoolctl, an independent reader of the loaded BLAS's thread count."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from imu_noise_id.cli.blas_threads import VARIABLES

#: Imports the command line, then reports the BLAS threads here and in a "spawn" worker (as analyze starts them).
SCRIPT = """
import json, multiprocessing
import imu_noise_id.cli
from threadpoolctl import threadpool_info

def blas_threads(_=None):
    return max(i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas")

if __name__ == "__main__":
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        worker = pool.map(blas_threads, [0])[0]
    print(json.dumps({"main": blas_threads(), "worker": worker}))
"""

#: The same without the command line: the BLAS's own default.
CONTROL = """
import numpy
from threadpoolctl import threadpool_info
print(max(i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"))
"""


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in VARIABLES}
    return {**env, **extra}


def _run(script: str, tmp_path, env: dict[str, str]) -> str:
    path = tmp_path / "probe.py"
    path.write_text(script)
    return subprocess.run([sys.executable, str(path)], env=env, check=True, capture_output=True, text=True,
                          timeout=120).stdout


def test_the_command_line_and_its_workers_run_one_blas_thread(tmp_path):
    threads = json.loads(_run(SCRIPT, tmp_path, _env()))
    assert threads == {"main": 1, "worker": 1}


@pytest.mark.skipif(len(os.sched_getaffinity(0)) < 2, reason="one core: the BLAS's default is one thread too")
def test_without_the_command_line_the_blas_would_start_one_thread_per_core(tmp_path):
    assert int(_run(CONTROL, tmp_path, _env())) == len(os.sched_getaffinity(0))


def test_an_explicit_thread_count_wins(tmp_path):
    threads = json.loads(_run(SCRIPT, tmp_path, _env(OPENBLAS_NUM_THREADS="2")))
    assert threads == {"main": 2, "worker": 2}
