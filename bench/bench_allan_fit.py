"""Accuracy of the Allan-slope parameters on simulated static IMUs with known noise (Monte Carlo).

Run: ``nice -n 10 python bench/bench_allan_fit.py [--runs R]`` (output in docs/results/bench_allan_fit.txt).
Each run simulates 1 h at 200 Hz of WN + RW on six axes (gyro N = 1.7e-4 rad/s/√Hz, K = 2e-5 rad/s²/√Hz;
accel N = 2e-3 m/s²/√Hz, K = 3e-4 m/s³/√Hz), computes the Allan variance and reads N and K with
:func:`imu_noise_id.core.allan.slopes.fit_axis_slopes`. Prints the relative errors (rms, max), how often
the 95 % intervals hold the truth, how often a parameter was only an upper bound, and how often a line the
records do not hold (QN, BI, RR) was read off them.
"""

from __future__ import annotations

import argparse

import numpy as np

from imu_noise_id.core.allan import allan_variance
from imu_noise_id.core.allan.slopes import fit_slopes
from imu_noise_id.core.axes import AXES, GYRO_AXES
from imu_noise_id.core.noise.components import RW, WN
from imu_noise_id.core.simulation.static import simulate_static_imu

TRUTH = {a: (1.7e-4, 2e-5) if a in GYRO_AXES else (2e-3, 3e-4) for a in AXES}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=20, help="simulated records (default 20, 6 axes each)")
    parser.add_argument("--duration", type=float, default=3600.0, help="record length [s] (default 3600)")
    parser.add_argument("--rate", type=float, default=200.0, help="sampling rate [Hz] (default 200)")
    args = parser.parse_args()
    model = {a: [WN(n), RW(k)] for a, (n, k) in TRUTH.items()}
    err = {"N": [], "K": []}
    inside = {"N": [], "K": []}
    bound = {"N": 0, "K": 0}
    spurious = {"QN": 0, "BI": 0, "RR": 0}
    for seed in range(args.runs):
        imu = simulate_static_imu(model, args.rate, args.duration, seed=1000 + seed)
        slopes = fit_slopes(allan_variance(imu.samples(), imu.dt))
        for axis, s in zip(AXES, slopes, strict=True):
            for name, comp in (("QN", s.quantization), ("BI", s.bias_instability), ("RR", s.rate_ramp)):
                spurious[name] += comp is not None
            for key, comp, truth in (("N", s.noise_density, TRUTH[axis][0]), ("K", s.random_walk, TRUTH[axis][1])):
                err[key].append(comp.value / truth - 1.0)
                inside[key].append(comp.ci[0] <= truth <= comp.ci[1])
                bound[key] += comp.method == "upper_bound"
    total = args.runs * len(AXES)
    print(f"{args.runs} records x 6 axes, {args.duration:g} s at {args.rate:g} Hz, WN + RW (seeds 1000..)")
    print(f"{'param':5s} {'rms err':>8s} {'max |err|':>9s} {'95% CI coverage':>16s} {'upper bounds':>13s}")
    for key in ("N", "K"):
        e = np.array(err[key])
        print(f"{key:5s} {100 * np.sqrt(np.mean(e**2)):7.2f}% {100 * np.max(np.abs(e)):8.2f}% "
              f"{100 * np.mean(inside[key]):15.1f}% {bound[key]:6d}/{total}")
    print("lines read that the records do not hold: " + ", ".join(f"{k} {v}/{total}" for k, v in spurious.items()))


if __name__ == "__main__":
    main()
