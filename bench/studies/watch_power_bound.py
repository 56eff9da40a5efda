"""The most any test can find within 60 s of bench_watch's faults, at the watch's false-alarm budget.

Usage (from the repository root; its output is a section of docs/results/bench_watch.txt)::

    PYTHONPATH=$PWD python bench/studies/watch_power_bound.py

bench_watch degrades gyro_z (WN 1.7e-4 + GM(30 s, 4e-5) + RW 2e-5 at 200 Hz) at 600 s and asks whether the watch
says so by 660 s. Two of its faults are found in under 95 % of the seeds: a bias step of 5 B and a 30 Hz line of
0.1 of the per-sample σ. This study computes, in closed form, the power of tests that know more than the watch can,
so that it bounds every test's:

- **Step**: the step's time, the true model and the size's sign known; 60 s after the step and 540 s before it. Its
  whitened signature s (the innovations of a unit step, the level's GLS coefficient removed, as the watch does)
  gives z = δ‖s‖ for a step δ, and the Neyman–Pearson test's power Φ(z − z_α) at level α. A test that must also
  find the time scans, which only raises its threshold. B is the truth model's bias instability (its Allan
  deviation's minimum / 0.664), larger than the reference's B that bench_watch sizes its steps with: the bound
  errs high.
- **Line**: 60 s of samples, all of them holding the line (the best segment any window could hold), white
  innovations of known variance, the frequency unknown among the M Fourier bins from the line test's lowest
  frequency (20 cycles in 60 s) to Nyquist: the maximum ordinate against h = ln(M/α), its power
  P(χ²₂(2ρ) > 2h) for the line's ordinate ρ = A²n/(4σ²).

Each at three shares of the unit's budget λ (0.1 false alarms per hour) per window test (every 10 s): the watch's
even split among 6 axes × 9 tests (the line test's half on the window's last 60 s), all tests of one axis on this
one, and the whole unit's budget on this one test.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from imu_noise_id.core.diagnostics.whitening import WhiteningFilter
from imu_noise_id.core.estimation.readouts.instability import bias_instability_from_allan
from imu_noise_id.core.noise.components import GM, RW, WN, total_allan_variance
from imu_noise_id.core.watch.innovation_tests import LINE_MIN_CYCLES
from imu_noise_id.core.watch.noise_level import TESTS_PER_AXIS
from imu_noise_id.core.watch.windowed import DEFAULT_EVERY_S

RATE_HZ = 200.0
TRUTH = [WN(1.7e-4), GM(tau=30.0, sigma=4e-5), RW(2e-5)]
WITHIN_S, BEFORE_S = 60.0, 540.0
UNIT_FALSE_ALARMS_PER_HOUR = 0.1
AXES = 6
#: (name, share of the unit's λ given to the one test).
SHARES = (("watch's even split", 1.0 / (AXES * TESTS_PER_AXIS)), ("one axis's whole share", 1.0 / AXES),
          ("the unit's whole budget", 1.0))


def step_signature(model, dt: float) -> float:
    """‖s‖ of a unit step after :data:`BEFORE_S` s, :data:`WITHIN_S` s of it, under ``model`` (module docstring)."""
    whitening = WhiteningFilter.from_components(model, dt)
    n = round((BEFORE_S + WITHIN_S) / dt)
    step = (np.arange(n) >= round(BEFORE_S / dt)).astype(float)
    s, constant = whitening.whiten(step), whitening.whiten(np.ones(n))
    return float(np.linalg.norm(s - constant * (constant @ s) / (constant @ constant)))


def main() -> None:
    dt = 1.0 / RATE_HZ
    taus = np.logspace(math.log10(dt), 4, 400)
    b = bias_instability_from_allan(taus, total_allan_variance(TRUTH, taus, dt)).value  # IEEE 952: ADEV min / 0.664
    norm = step_signature(TRUTH, dt)
    sigma = TRUTH[0].noise_density / math.sqrt(dt)
    n = round(WITHIN_S / dt)
    bins = round((0.5 / dt - LINE_MIN_CYCLES / WITHIN_S) * WITHIN_S)
    print(f"truth: {TRUTH} at {RATE_HZ:g} Hz; B = {b:.3g} rad/s; per-sample sigma = {sigma:.3g} rad/s; "
          f"{WITHIN_S:g} s after the change, windows every {DEFAULT_EVERY_S:g} s; the unit's budget "
          f"{UNIT_FALSE_ALARMS_PER_HOUR:g} false alarms per hour")
    print("\n| fault | best test's statistic | " + " | ".join(f"power at {name}" for name, _ in SHARES) + " |")
    print("|---|---|" + "---|" * len(SHARES))
    alphas = [UNIT_FALSE_ALARMS_PER_HOUR * share * DEFAULT_EVERY_S / 3600.0 for _, share in SHARES]
    for k in (5, 10):
        z = k * b * norm
        powers = [stats.norm.sf(stats.norm.isf(alpha / 2) - z) for alpha in alphas]
        print(f"| bias step {k} B, time and model known | z = {z:.2f} | " + " | ".join(f"{p:.2f}" for p in powers)
              + " |")
    for amplitude in (0.1, 0.2):
        rho = (amplitude * sigma) ** 2 * n / (4 * sigma**2)
        # the watch's line test has half its share on the window's last 60 s: the even split's alpha halved
        powers = [stats.ncx2.sf(2 * math.log(bins / (alpha / 2 if i == 0 else alpha)), 2, 2 * rho)
                  for i, alpha in enumerate(alphas)]
        print(f"| 30 Hz line {amplitude:g} sigma, 60 s of it, variance known | ordinate {rho:.1f} over {bins} bins | "
              + " | ".join(f"{p:.2f}" for p in powers) + " |")


if __name__ == "__main__":
    main()
