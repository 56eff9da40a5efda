"""CPU time of the closed loop on measured axes, this checkout against other checkouts side by side.

An axis is ``RUN:AXIS`` of the ADIS16405 static runs or ``broadTRIAL:AXIS`` of a BROAD trial's rest before its
motion (a consumer module's short record, ``bench/common.py``). Each axis (its first ``--samples`` samples) runs the
loop from WN+RW once per source tree, the trees in alternation
and each in its own process with ``OPENBLAS_NUM_THREADS=1``, so that a speed claim is a ratio measured side by side
in one run. Printed per axis and tree: the process's CPU time, the final model, its log-likelihood (full
precision) and whether model, log-likelihood (to the last digit) and verdict equal the first tree's (each tree's
package is checked to be the one imported)::

    git worktree add ../baseline <commit>
    .venv/bin/python bench/studies/bench_loop_measured_time.py --baseline ../baseline --axes 1:accel_x broad10:gyro_x

Needs ``../shared/data/adis16405_static`` and, for the BROAD axes, ``../shared/data/broad_trials`` (third-party
data, not in the repository). What it found is in docs/loop.md (Limitations) and docs/em.md (Algorithm,
5. Quasi-Newton finish); its last output is docs/results/studies/likelihood_speed.txt.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # bench/, for its shared helpers

from common import adis_data_missing, run_in_checkout  # bench/common.py

ROOT = Path(__file__).resolve().parents[2]

#: Run in each source tree: the loop on one axis, one JSON line (model, log-likelihood as repr, verdict).
ONE_AXIS = """
import json, sys
sys.path.insert(0, {bench!r})
from common import {loader}
from imu_noise_id.core.axes import AXES
from imu_noise_id.pipelines.loop.run import run_closed_loop
data, dt = {loader}({run}, {samples})
r = run_closed_loop(data[:, AXES.index({axis!r})], dt, "WN+RW", axis={axis!r})
fit = r.steps[-1].diagnosis.fit
print(json.dumps({{"model": fit.model, "loglik": repr(fit.loglik), "verdict": r.verdict}}))
"""


def run_axis(source: Path, record: str, axis: str, samples: int) -> tuple[float, dict]:
    """(CPU [s] of the child, its JSON line) of the loop on one axis of ``record`` (an ADIS16405 run's number or
    ``broadTRIAL``) with ``source``'s package."""
    broad = record.startswith("broad")
    code = ONE_AXIS.format(bench=str(ROOT / "bench"), loader="load_broad_rest" if broad else "load_adis_run",
                           run=int(record.removeprefix("broad")), samples=samples, axis=axis)
    return run_in_checkout(source, code, f"the loop on {record} {axis}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--axes", nargs="+", default=["1:accel_x"],
                        help="RUN:AXIS or broadTRIAL:AXIS pairs (default 1:accel_x)")
    parser.add_argument("--samples", type=int, default=100_000, help="first samples of each run (default 10^5)")
    parser.add_argument("--baseline", type=Path, action="append", default=[], help="another checkout (repeatable)")
    args = parser.parse_args(argv)
    if adis_data_missing():
        return 2
    sources = [("this checkout", ROOT), *[(f"baseline {p}", p.resolve()) for p in args.baseline]]
    print(f"# bench/studies/bench_loop_measured_time.py --samples {args.samples}; {os.cpu_count()} CPUs; load average "
          f"before {os.getloadavg()[0]:.2f}")
    for pair in args.axes:
        record, axis = pair.split(":")
        label = f"BROAD {record.removeprefix('broad')} rest" if record.startswith("broad") else f"run {record}"
        first: dict | None = None
        for name, source in sources:
            cpu, out = run_axis(source, record, axis, args.samples)
            first = first or out
            same = all(out[key] == first[key] for key in ("model", "loglik", "verdict"))
            print(f"{label} {axis:8s} {name:40s} CPU {cpu:7.1f} s  {out['model']}  loglik {out['loglik']}  "
                  f"{'identical' if same else 'DIFFERENT'} to the first", flush=True)
    print(f"load average after {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
