"""Coverage of the Allan-variance confidence intervals on seeded white noise and random walk.

Run: ``nice -n 10 python bench/bench_allan_ci.py`` (output in docs/results/bench_allan_ci.txt).
400 series of 4000 samples each; at several m the fraction of series whose 95 % interval holds the true AV
(noise type identified from each curve, as in ``analyze``), with the median EDF.
"""

from __future__ import annotations

import math

import numpy as np

from imu_noise_id.core.allan import allan_variance
from imu_noise_id.core.noise.components import RW, WN

DT = 0.01
SERIES = 400
N = 4000


def report(name: str, y: np.ndarray, truth) -> None:
    res = allan_variance(y, DT)
    for m in (1, 4, 18, 100, 178, 316, 1000):
        hit = np.flatnonzero(res.m == m)
        if hit.size == 0:
            continue
        i = int(hit[0])
        t = float(truth(m * DT))
        cover = np.mean((res.ci_low[i] <= t) & (t <= res.ci_high[i]))
        print(f"{name:12s} m={m:5d}  coverage {100 * cover:5.1f} %  median EDF {np.median(res.edf[i]):10.1f}")


def main() -> None:
    rng = np.random.default_rng(11)
    print(f"{SERIES} series x {N} samples, dt = {DT} s, nominal 95 % (binomial sd of the rate 1.1 %)")
    report("white noise", rng.standard_normal((N, SERIES)), lambda tau: WN(math.sqrt(DT)).allan_variance(tau, DT))
    k = 1e-3
    walk = np.cumsum(rng.standard_normal((N, SERIES)) * k * math.sqrt(DT), axis=0)
    report("random walk", walk, lambda tau: RW(k).allan_variance(tau, DT))


if __name__ == "__main__":
    main()
