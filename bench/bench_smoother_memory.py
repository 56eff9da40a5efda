"""Memory and time of one exact score evaluation (the likelihood and its gradient, one filter and one smoother pass:
what the maximum-likelihood finish and the intervals repeat) at the structures and lengths of real records, side by
side.

Each cell runs in each checkout given, one after the other, each in its own process (``common.run_in_checkout``, one
BLAS thread)::

    .venv/bin/python bench/bench_smoother_memory.py --baseline ../baseline

Cells (``CELLS``): the Kalibr model WN+RW and a measured sensor's structure (a white noise, a first-order low-pass, a
flicker ladder over the record, six oscillators, a GM of 100 s and a walk: the whole-record ADIS16405 gyro_z's final
model has this many states) over 10⁶ samples at 100 Hz (2.78 h), 4·10⁶ at 200 Hz (5.6 h, the longest record the
default ``analyze`` fits with the EM) and 1.728·10⁷ at 200 Hz (24 h, ``--estimator em``). The record is white
noise plus a walk from a fixed seed, simulated in the child before the measurement (its size is not counted); the
structure, not the data, sets the smoother's memory. Timed: ``mle.loglik_and_grad`` at the structure's own
parameters, the median of ``--repeats`` calls (one at 24 h). Printed per cell and checkout: the states p, p·N, the wall
time of one evaluation and the peak RSS the evaluations added to the process (``ru_maxrss`` after them less before).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from common import run_in_checkout  # bench/common.py, beside this script

from imu_noise_id.pipelines.analyze.models import EM_MAX_SAMPLES

ROOT = Path(__file__).resolve().parents[1]

#: (name, samples, sample rate [Hz]) of each cell's record; the structure by name in ``CODE``. 4·10⁶ samples is the
#: longest record the default ``analyze`` fits with the EM and the closed loop (``EM_MAX_SAMPLES``; the GMWM beyond).
CELLS = (("WN+RW", 1_000_000, 100.0), ("sensor", 1_000_000, 100.0), ("sensor", EM_MAX_SAMPLES, 200.0),
         ("WN+RW", 17_280_000, 200.0), ("sensor", 17_280_000, 200.0))

CODE = """
import json, resource, statistics, time
import numpy as np
from imu_noise_id.core.estimation.em import mle
from imu_noise_id.core.kalman import statespace as ss
from imu_noise_id.core.noise.components import GM, RW, WN
from imu_noise_id.core.noise.flicker import BI
from imu_noise_id.core.noise.resonant import LPF, OSC

n, dt, repeats = {n}, {dt}, {repeats}
if "{structure}" == "WN+RW":
    comps = [WN(7e-4), RW(1e-5)]
else:
    comps = ([WN(7e-4), LPF(noise_density=2e-3, cutoff=15.0), BI(1e-4, 0.05, n * dt)]
             + [OSC(frequency=f, bandwidth=0.5, sigma=2e-3) for f in (0.56, 1.7, 10.0, 19.8, 20.7, 24.8)]
             + [GM(tau=100.0, sigma=1e-4), RW(1e-5)])
rng = np.random.default_rng(0)
y = rng.standard_normal(n) * 7e-4 / dt**0.5 + np.cumsum(rng.standard_normal(n)) * 1e-5 * dt**0.5
z = np.ones((n, 1))
base = ss.from_components(comps, dt, exog_names=[])
par = mle.Parameterisation.of(comps)
theta = par.to_theta(comps)
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
seconds = []
for _ in range(repeats):
    start = time.perf_counter()
    loglik, grad, _ = mle.loglik_and_grad(par, theta, base, y, z)
    seconds.append(time.perf_counter() - start)
added = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
print(json.dumps({{"p": base.n_states, "seconds": statistics.median(seconds), "added_mib": added,
                  "loglik": loglik, "grad_norm": float(np.linalg.norm(grad))}}))
"""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--baseline", type=Path, help="another checkout, run side by side")
    ap.add_argument("--repeats", type=int, default=3, help="evaluations per cell below 24 h (median timed)")
    args = ap.parse_args(argv)
    trees = [("this checkout", ROOT)] + ([("baseline", args.baseline.resolve())] if args.baseline else [])
    for structure, n, rate in CELLS:
        for label, source in trees:
            repeats = 1 if n > 5_000_000 else args.repeats
            code = CODE.format(n=n, dt=1.0 / rate, repeats=repeats, structure=structure)
            _, r = run_in_checkout(source, code, f"{structure} over {n} samples")
            print(f"{structure:7s} {n:>10,d} samples at {rate:5.0f} Hz  {label:14s}  p {r['p']:2d}  "
                  f"p·N {r['p'] * n:.3g}  {r['seconds']:7.2f} s per evaluation  "
                  f"peak RSS added {r['added_mib']:7.0f} MiB  "
                  f"(loglik {r['loglik']:.6f}, |grad| {r['grad_norm']:.6g})", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
