"""How far the composite likelihood's maximiser is from the exact one on a measured axis, and what the exact finish
spends closing the gap.

The closed loop on one whole ADIS16405 axis (10⁶ samples) searches on the composite likelihood and ends with the exact
finish (``pipelines/loop/run.exact_finish``). This study takes the loop's final model (at the exact maximum), fits
its structure on the composite likelihood from there (``composite.fit_model``: the maximiser evaluated once on the
exact likelihood) and fits it exactly again from that point, printing the exact log-likelihood gained after every
evaluation of the finish (time since its start)::

    PYTHONPATH=$PWD OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/studies/composite_gap.py --run 1 --axes gyro_z accel_x

About 8–13 minutes per axis. Needs ``../shared/data/adis16405_static`` (third-party data, not in the repository).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # bench/, for its shared helpers

from common import adis_data_missing, load_adis_run  # bench/common.py

from imu_noise_id.core.axes import AXES
from imu_noise_id.core.estimation.em import composite, mle
from imu_noise_id.core.estimation.em.model import FitOptions, NoiseModel
from imu_noise_id.pipelines.loop import run_closed_loop


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", type=int, default=1)
    parser.add_argument("--axes", nargs="+", default=["gyro_z", "accel_x"], choices=AXES)
    args = parser.parse_args(argv)
    if adis_data_missing():
        return 2
    data, dt = load_adis_run(args.run, 0)
    for i, axis in enumerate(args.axes):
        if i:
            print()
        _study(data[:, AXES.index(axis)], dt, args.run, axis)
    return 0


def _study(y, dt: float, run: int, axis: str) -> None:
    start = time.perf_counter()
    loop = run_closed_loop(y, dt, "WN+RW", axis=axis)
    final = loop.steps[-1].diagnosis.fit
    print(f"ADIS16405 run {run} {axis}, {y.size} samples: the loop ended with {final.model} after "
          f"{time.perf_counter() - start:.0f} s; exact log-likelihood {final.loglik:.2f}", flush=True)
    model = NoiseModel(y, dt, final.model)
    at_composite = composite.fit_model(model, [list(final.components)], composite.CompositeStatistics.of(y, dt))
    print(f"composite maximiser from there: exact log-likelihood {at_composite.loglik:.2f}, "
          f"{final.loglik - at_composite.loglik:.1f} below the exact maximum", flush=True)
    trace: list[tuple[float, float]] = []
    evaluate = mle.loglik_grad_profile

    def traced(*a, **k):
        out = evaluate(*a, **k)
        trace.append((time.perf_counter() - began, out[0]))
        return out

    mle.loglik_grad_profile = traced
    began = time.perf_counter()
    again = model.fit(list(at_composite.components), FitOptions(uncertainty=False))
    mle.loglik_grad_profile = evaluate
    print(f"exact fit from the composite maximiser: log-likelihood {again.loglik:.2f} after "
          f"{time.perf_counter() - began:.0f} s and {len(trace)} evaluations with gradient\n"
          "evaluation  time [s]  best gain so far")
    best = -float("inf")
    for i, (t, ll) in enumerate(trace, 1):
        best = max(best, ll - at_composite.loglik)
        print(f"{i:10d}  {t:8.1f}  {best:16.2f}", flush=True)


if __name__ == "__main__":
    sys.exit(main())
