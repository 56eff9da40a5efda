"""Run code against another checkout of the project, in its own process, and check which package it imported.

Shared by the side-by-side benches (``bench_analyze_time``, ``bench_loop_measured_time``, ``bench_steady_engine``):
a speed claim is a ratio between checkouts only if each process imported its own checkout's package. The child
runs with PYTHONPATH and the working directory both set to the checkout (``python -m`` and ``-c`` put the working
directory before PYTHONPATH: run from the repository root, every checkout would import the root's package).
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
from pathlib import Path

#: Appended to the code of :func:`run_in_checkout`: the package the child imported, for the check.
_PACKAGE = "\nimport imu_noise_id as _pkg\nprint(json.dumps({'package': _pkg.__file__}))\n"


def run_in_checkout(source: Path, code: str, what: str) -> tuple[float, dict]:
    """(CPU [s] of the child, the JSON object its code printed on the line before the last) of ``python -c code``
    run in ``source`` (PYTHONPATH too, one BLAS thread); SystemExit naming ``what`` if it fails or imported another
    checkout's package.

    ``code`` must import ``json`` and print its result as one JSON line last; the package check prints after it.
    """
    env = dict(os.environ, PYTHONPATH=str(source), OPENBLAS_NUM_THREADS="1")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run([sys.executable, "-c", code + _PACKAGE], env=env, cwd=source, capture_output=True,
                          text=True, check=False)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"{what} from {source} failed:\n{done.stderr}")
    *_, result, package = done.stdout.strip().splitlines()
    package = json.loads(package)["package"]
    if not Path(package).is_relative_to(source):
        raise SystemExit(f"run from {source}, {what} imported {package}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, json.loads(result)


def check_imports_own_package(source: Path, what: str) -> None:
    """SystemExit unless a process run in ``source`` with PYTHONPATH=``source`` imports ``source``'s package: the
    check for a command the caller starts itself that way (e.g. ``python -m imu_noise_id analyze``)."""
    run_in_checkout(source, "import json\nprint(json.dumps(None))\n", what)
