"""The sampled processes' sums (core/noise/sampled.py) against direct summation and numpy's expm1."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imu_noise_id.core.noise.sampled import EXPM1_BELOW, complex_expm1, lag_weighted_sum


def test_complex_expm1_is_numpys_near_zero_and_exp_less_one_beyond():
    rng = np.random.default_rng(7)
    radius = np.exp(rng.uniform(math.log(1e-12), math.log(60.0), 4000))
    x = radius * np.exp(1j * rng.uniform(0.5 * math.pi, 1.5 * math.pi, radius.size))  # decaying: Re x ≤ 0
    x = np.concatenate([x, 1j * 2.0 * math.pi * np.arange(1, 50) - 1e-9])  # e^x ≈ 1 far from x = 0
    out, reference = complex_expm1(x), np.expm1(x)
    near = np.abs(x) < EXPM1_BELOW
    assert np.array_equal(out[near], reference[near])
    assert np.all(np.abs(out[~near] - reference[~near]) <= 1e-15 * np.maximum(1.0, np.abs(np.exp(x[~near]))))


@pytest.mark.parametrize("w", [-1e-6 + 2e-4j, -2e-5 + 0.0314j, -3e-3 + 0.6j, -0.5 + 2.5j])
def test_lag_weighted_sum_is_the_direct_sum(w):
    """g(m) = Σ_{j<m} (m − j) e^{jw} on both sides of the series limit and where m·Im w passes multiples of 2π."""
    m = np.unique(np.concatenate([np.arange(0, 40), np.geomspace(40, 20000, 60).astype(int)])).astype(float)
    g = lag_weighted_sum(m, np.array(w))
    for mi, gi in zip(m.astype(int), g, strict=True):
        j = np.arange(1, mi, dtype=float)
        direct = complex(np.sum((mi - j) * np.exp(j * w)))
        assert abs(gi - direct) <= 1e-9 * max(abs(direct), mi), mi
