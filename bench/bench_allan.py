"""Allan variance of 10⁷ samples × 6 axes: imu_noise_id vs allantools (same τ, same values).

Run: ``nice -n 10 python bench/bench_allan.py [--n N]`` (output saved in docs/results/bench_allan.txt).
Prints both run times, their ratio and the largest relative difference of the variances over all τ and axes.
allantools is called once per axis (``oadev``, ``data_type="freq"``) with our τ grid; our time includes the
confidence intervals (EDF and χ²), allantools' does not.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import allantools
import numpy as np

from imu_noise_id.core.allan import allan_variance, choose_m


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=10_000_000, help="samples per axis (default 1e7)")
    parser.add_argument("--rate", type=float, default=200.0, help="sampling rate [Hz] (default 200)")
    args = parser.parse_args()
    dt = 1.0 / args.rate
    rng = np.random.default_rng(0)
    scale = np.array([1.7e-4, 1.7e-4, 1.7e-4, 2e-3, 2e-3, 2e-3]) / np.sqrt(dt)
    y = rng.standard_normal((args.n, 6)) * scale
    y += np.cumsum(rng.standard_normal((args.n, 6)), axis=0) * scale * 1e-3
    y[:, 5] += 9.81
    m = choose_m(args.n, "allan")
    print(f"python {platform.python_version()}, numpy {np.__version__}, allantools {allantools.__version__}, "
          f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}")
    print(f"data: {args.n} samples x 6 axes at {args.rate:g} Hz; {m.size} log-spaced tau from {m[0] * dt:g} s "
          f"to {m[-1] * dt:g} s (8 per decade)")

    t0 = time.perf_counter()
    ours = allan_variance(y, dt, m=m)
    t_ours = time.perf_counter() - t0

    t0 = time.perf_counter()
    ref = np.empty_like(ours.variance)
    for j in range(6):
        taus, dev, _, _ = allantools.oadev(y[:, j], rate=args.rate, data_type="freq", taus=m * dt)
        if taus.size != m.size:
            raise SystemExit("allantools dropped some tau: results not comparable")
        ref[:, j] = dev**2
    t_ref = time.perf_counter() - t0

    rel = np.max(np.abs(ours.variance / ref - 1.0))
    print(f"imu_noise_id allan_variance (values + 95% CIs): {t_ours:7.2f} s")
    print(f"allantools oadev, 6 calls (values only):         {t_ref:7.2f} s")
    print(f"speed ratio allantools/imu_noise_id:             {t_ref / t_ours:7.2f}x")
    print(f"max relative difference of the variances:        {rel:.2e}")


if __name__ == "__main__":
    main()
