"""Time of one likelihood-and-gradient evaluation's N-dependent work, this checkout against other checkouts.

What every L-BFGS evaluation of a fit does with the data (``mle.loglik_grad_profile``): the steady engine's filter
over the data and regressor columns, the GLS profile, the predicted states and the backward smoother
(``kalman.profile_and_smooth``), then the E-step sums (``em.sums_from_stats``). On a full 10⁶-sample record that is
almost all of a loop's time (1257 of the first 1500 s on ADIS16405 run 3 gyro_x:
``bench/studies/profile_loop_measured.py``). Each tree runs in its own process (``OPENBLAS_NUM_THREADS=1``, the
package imported from that tree, checked), the trees in alternation, ``--repeats``
times each; per model, length and basis it prints the median and the smallest time of ``--evaluations`` evaluations,
the share spent inside ``scipy.signal.lfilter`` (the recursions themselves; the rest is array passes: inputs, basis
changes, reversals) and whether the log-likelihood and a digest of every E-step statistic equal the first tree's to
the last bit::

    git worktree add ../baseline <commit>
    .venv/bin/python bench/studies/bench_steady_engine.py --baseline ../baseline

The models: an ADIS16405 gyro's loop model (WN+MA+BI+2OSC+RW, 14 states: a flicker ladder, a 0.55 Hz and an
8.7 Hz resonance) and the Kalibr-like WN+GM+RW, each with the bias as a regressor, on a simulated record of white
noise and a random walk at 100 Hz; in the modal basis (the default where it is well conditioned) and in the Schur
basis (forced by ``MODAL_MAX_COND = 0``). What it found is in docs/em.md (Algorithm, 1. Kalman engines) and
docs/loop.md (Limitations); its last output is docs/results/studies/likelihood_speed.txt.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # bench/, for its shared helpers

from common import run_in_checkout  # bench/common.py

ROOT = Path(__file__).resolve().parents[2]

#: Run in each source tree: the evaluations of every case, one JSON line.
ONE_TREE = """
import hashlib, json, time
import numpy as np
from imu_noise_id.core import kalman
try:  # the E-step's module (the estimation package's em.py itself in older checkouts)
    from imu_noise_id.core.estimation.em import em
except ImportError:
    from imu_noise_id.core.estimation import em
from imu_noise_id.core.kalman import steady
try:  # where the modal basis's condition bound lives (steady.py itself in older checkouts)
    from imu_noise_id.core.kalman import basis as bases
except ImportError:
    bases = steady
try:  # where the block filters call lfilter (steady.py itself in older checkouts)
    from imu_noise_id.core.kalman import blockfilter as filters
except ImportError:
    filters = steady
from imu_noise_id.core.kalman.statespace import from_components
from imu_noise_id.core.noise.averaging import MA
from imu_noise_id.core.noise.components import GM, RW, WN
from imu_noise_id.core.noise.flicker import BI
from imu_noise_id.core.noise.resonant import OSC

spent = [0.0]
plain = filters.lfilter
def timed(*args, **kwargs):
    start = time.perf_counter()
    try:
        return plain(*args, **kwargs)
    finally:
        spent[0] += time.perf_counter() - start
filters.lfilter = timed

MODELS = {{"WN+MA+BI+2OSC+RW": [WN(6.8e-4), MA(1e-4), BI(3e-5, 1.0, 1000.0), OSC(0.55, 0.005, 2e-4),
                                OSC(8.7, 0.4, 5e-4), RW(1e-5)],
          "WN+GM+RW": [WN(6.8e-4), GM(tau=3.0, sigma=1e-4), RW(1e-5)]}}
modal_cond = bases.MODAL_MAX_COND
rows = []
for n in {lengths}:
    rng = np.random.default_rng(7)
    y = 1e-3 * rng.standard_normal(n) + 1e-5 * np.cumsum(rng.standard_normal(n))
    z = np.ones((n, 1))
    data = em.DataSums.of(y, z)
    for name, comps in MODELS.items():
        model = from_components(comps, 0.01)
        for basis, cond in (("modal", modal_cond), ("Schur", 0.0)):
            bases.MODAL_MAX_COND = cond
            times, shares = [], []
            for k in range({evaluations} + 1):  # the first one warms up
                spent[0] = 0.0
                start = time.perf_counter()
                prof, _, stats = kalman.profile_and_smooth(model.copy(), y, z)
                em.sums_from_stats(stats, data)
                if k:
                    times.append(time.perf_counter() - start)
                    shares.append(spent[0] / times[-1])
            digest = hashlib.sha256()
            for value in vars(stats).values():
                if isinstance(value, np.ndarray):
                    digest.update(np.ascontiguousarray(value).tobytes())
            rows.append({{"n": n, "model": name, "basis": basis, "times": times, "lfilter_share": shares,
                         "loglik": repr(float(prof.loglik)), "digest": digest.hexdigest()}})
print(json.dumps(rows))
"""


def run_tree(source: Path, lengths: list[int], evaluations: int) -> list[dict]:
    """The rows of one process running every case with ``source``'s package."""
    code = ONE_TREE.format(lengths=lengths, evaluations=evaluations)
    return run_in_checkout(source, code, "the evaluations")[1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lengths", type=int, nargs="+", default=[100_000, 1_000_000], help="samples per record")
    parser.add_argument("--evaluations", type=int, default=5, help="timed evaluations per case and process")
    parser.add_argument("--repeats", type=int, default=2, help="processes per tree, in alternation")
    parser.add_argument("--baseline", type=Path, action="append", default=[], help="another checkout (repeatable)")
    args = parser.parse_args(argv)
    sources = [("this checkout", ROOT), *[(f"baseline {p}", p.resolve()) for p in args.baseline]]
    print(f"# bench/studies/bench_steady_engine.py --lengths {' '.join(map(str, args.lengths))} --evaluations "
          f"{args.evaluations} --repeats {args.repeats}; {os.cpu_count()} CPUs; load average before "
          f"{os.getloadavg()[0]:.2f}")
    runs: dict[str, list[list[dict]]] = {name: [] for name, _ in sources}
    for _ in range(args.repeats):
        for name, source in sources:
            runs[name].append(run_tree(source, args.lengths, args.evaluations))
    first = runs[sources[0][0]][0]
    for i, case in enumerate(first):
        print(f"\n{case['n']} samples, {case['model']}, {case['basis']} basis:")
        median_first = None
        for name, _ in sources:
            rows = [run[i] for run in runs[name]]
            times = [t for row in rows for t in row["times"]]
            share = statistics.median(s for row in rows for s in row["lfilter_share"])
            median = statistics.median(times)
            median_first = median_first or median
            same = all(row["loglik"] == case["loglik"] and row["digest"] == case["digest"] for row in rows)
            print(f"  {name:40s} median {median:7.3f} s  min {min(times):7.3f} s  lfilter {share:4.0%}  "
                  f"{median / median_first:5.2f}× the first  loglik {rows[0]['loglik']}  "
                  f"{'identical' if same else 'DIFFERENT'} to the first")
    print(f"\nload average after {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
