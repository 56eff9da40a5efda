"""The data's passband level from the record's spectrum (``readouts.passband``) against the truth it was simulated
with: white noise beside a walk, and white noise behind a digital low-pass with a floor after it."""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

from imu_noise_id.core.estimation.readouts.passband import passband_level
from imu_noise_id.core.noise.components import GM, RW, WN, simulate_sum
from imu_noise_id.core.noise.digital import DLPF


def test_the_interval_covers_the_white_noise_beside_a_walk():
    """95 % intervals of N on 200 records of WN + RW (60k samples at 200 Hz) hold the truth on 88–99 % of them."""
    held = []
    for seed in range(200):
        y = simulate_sum([WN(1e-3), RW(2e-5)], 60_000, 0.005, np.random.default_rng(seed))
        level = passband_level(y, 0.005, [WN(1e-3), RW(2e-5)])
        held.append(level.ci[0] <= 1e-3 <= level.ci[1])
    assert 0.88 <= np.mean(held) <= 0.99


def test_behind_a_low_pass_the_band_is_its_passband_and_the_level_its_density():
    """A second-order Butterworth at 20 Hz sampled at 1 kHz over a floor of a tenth: the band ends below the cutoff
    (the filter's gain within 10 % of 1) and the level is the passband density √(N² + floor²)."""
    rng = np.random.default_rng(3)
    w = rng.standard_normal(124_000) * 1e-3 * math.sqrt(1000.0)
    y = signal.sosfilt(signal.butter(2, 20.0, fs=1000.0, output="sos"), w)[4000:]
    y = y + simulate_sum([WN(1e-4)], y.size, 0.001, rng)
    level = passband_level(y, 0.001, [WN(1e-4), DLPF(1e-3, 20.0, 2)])
    assert level.band_hz[1] < 20.0
    assert abs(level.value / math.hypot(1e-3, 1e-4) - 1) < 0.03
    assert level.ci[0] < level.value < level.ci[1]


def test_no_level_without_white_noise_in_the_model_or_a_band_to_read_it_from():
    y = simulate_sum([WN(1e-3), GM(tau=1.0, sigma=1e-2)], 20_000, 0.01, np.random.default_rng(1))
    assert passband_level(y, 0.01, [GM(tau=1.0, sigma=1e-2)]) is None  # nothing in the model enters N
    assert passband_level(y[:100], 0.01, [WN(1e-3)]) is None  # too short for a Welch band
