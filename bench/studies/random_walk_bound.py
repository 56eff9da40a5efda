"""How close to K *any* estimator could come in bench_random_walk's cells (issue "the random walk users paste"): the
Cramér–Rao bound of ln K when the true structure is known, and the median |ln(K̂/K)| it implies.

Run:  .venv/bin/python bench/studies/random_walk_bound.py [--minutes 20 60 180] [--cells …]
(output: a section of docs/results/studies/probe_k_information.txt; seconds per cell; no simulation, no fit)

The truth of each cell is bench_random_walk's (``bench_random_walk.components``: N = 5·10⁻⁴, K = 2·10⁻⁵ at 200 Hz,
beside nothing, a GM of τ 20 s or 100 s whose AV peak is the walk's AV at 100 s, a flicker of that plateau, or a
0.5 Hz oscillation). Whittle's Fisher information of the record's differences (``probe_k_information``'s
``fisher_information``, every Fourier frequency) gives ``sd(ln K)`` = √(I⁻¹)_KK, the smallest standard deviation an
unbiased estimator that knows the structure can reach to leading order in n. For such an efficient estimator ln K̂ is
normal about ln K, so its median |ln(K̂/K)| is ``0.674·sd`` (``best median``): a bench target below it asks more
than the record holds, whatever the search. ``P(|ln| ≤ 0.25)`` is the share of records in which that estimator is
within ±28 %.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # bench/, for its shared helpers

import numpy as np
from bench_random_walk import CELLS, RATE_HZ, components
from probe_k_information import fisher_information, fourier_omega
from scipy.stats import norm

from imu_noise_id.core.estimation.em.mle import Parameterisation

#: The median of |Z| for a standard normal Z.
HALF_NORMAL_MEDIAN = float(norm.ppf(0.75))
#: bench_random_walk's median |ln(K̂/K)| target at 1 h and 3 h.
TARGET = 0.25


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, nargs="+", default=[20.0, 60.0, 180.0])
    ap.add_argument("--cells", nargs="+", default=list(CELLS), choices=list(CELLS))
    args = ap.parse_args()
    dt = 1.0 / RATE_HZ
    print(f"# bench/studies/random_walk_bound.py --minutes {' '.join(f'{m:g}' for m in args.minutes)} "
          f"(bench_random_walk's cells at {RATE_HZ:g} Hz; an efficient estimator that knows the structure)")
    for minutes in args.minutes:
        n = int(minutes * 60 * RATE_HZ)
        omega = fourier_omega(n)
        for cell in args.cells:
            comps = components(cell, n, dt)
            k = Parameterisation.of(comps).entries.index((len(comps) - 1, "random_walk"))  # the walk is last
            sd = math.sqrt(np.linalg.inv(fisher_information(comps, omega, dt=dt))[k, k])
            within = float(2.0 * norm.cdf(TARGET / sd) - 1.0)
            print(f"{minutes:5g} min  {cell:12s}  CRB sd(ln K) {sd:5.3f}  best median |ln(K/K_true)| "
                  f"{HALF_NORMAL_MEDIAN * sd:5.3f}  P(|ln| <= {TARGET:g}) {within:5.3f}", flush=True)


if __name__ == "__main__":
    main()
