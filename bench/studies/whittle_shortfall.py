"""How far short of the banded Whittle maximum L-BFGS-B's own stopping rule leaves ``whittle_fit``, per caller, on a
measured axis run through ``analyze``.

Every Whittle fit that ``analyze`` makes on the axis is redone both ways, with L-BFGS-B's stopping rule (relative to
|ℓ| ~ N) and climbed on ``to_maximum``; printed per caller (``screen.py``: the screen's gains, a difference of two
maxima; ``model.py``: a fit's starts; ``composite.py``: the composite fit's moved start) the number of fits and the
median, 90th percentile and largest shortfall of the first in log-likelihood units, and how many fall short by more
than one. Needs ``../shared/data`` (the ADIS16405 recordings); skips without it::

    .venv/bin/python bench/studies/whittle_shortfall.py --run 1 --axis gyro_x
"""

from __future__ import annotations

import argparse
import collections
import inspect
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "adis16405_static"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=int, default=1)
    ap.add_argument("--axis", default="gyro_x")
    args = ap.parse_args(argv)
    path = DATA / f"adis16405_run{args.run}.npz"
    if not path.exists():
        print(f"skipped: {path} not found (../shared/data)")
        return 0
    sys.path.insert(0, str(ROOT))
    from imu_noise_id.core.axes import ImuSeries
    from imu_noise_id.core.estimation.em import whittle
    from imu_noise_id.pipelines.analyze import AnalyzeOptions, analyze

    fit = whittle.whittle_fit
    shortfalls: dict[str, list[float]] = collections.defaultdict(list)

    def measured(start: list, y: np.ndarray, dt: float, periodogram: object = None, bounds: dict | None = None,
                 **kwargs: bool) -> tuple:
        result = fit(start, y, dt, periodogram, bounds, **kwargs)
        stopped = fit(start, y, dt, periodogram, bounds)[0]
        climbed = fit(start, y, dt, periodogram, bounds, to_maximum=True)[0]
        if np.isfinite(stopped):
            shortfalls[Path(inspect.stack()[1].filename).name].append(climbed - stopped)
        return result

    whittle.whittle_fit = measured
    d = np.load(path)
    imu = ImuSeries(t=d["t"], gyro=d["gyro"], accel=d["accel"], frame_id="imu", topic="/imu/data")
    analyze(imu, None, AnalyzeOptions(axes=(args.axis,), jobs=1))
    print(f"# bench/studies/whittle_shortfall.py --run {args.run} --axis {args.axis}: ADIS16405 run {args.run} "
          f"{args.axis}, whole record ({d['t'].size} samples), analyze's default stages")
    print("# shortfall of L-BFGS-B's own stop below the maximum, in log-likelihood units")
    print("caller          fits     median      p90      max  short by > 1")
    for caller, values in sorted(shortfalls.items()):
        v = np.array(values)
        print(f"{caller:14s} {v.size:5d} {np.median(v):10.3f} {np.percentile(v, 90):8.2f} {v.max():8.1f} "
              f"{int(np.sum(v > 1.0)):13d}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
