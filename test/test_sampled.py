"""The sampled processes' sums (core/noise/sampled.py) against direct summation and numpy's expm1."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imu_noise_id.core.noise.sampled import (
    EXPM1_BELOW,
    block_sum_variance,
    complex_expm1,
    consecutive_block_sum_variance,
    lag_weighted_sum,
)


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


def _block_sum_variance_long(c: complex, w: complex, size: int) -> np.ndarray:
    """S(k) = Re(c(k + 2g(k))) at k = 0 … size − 1 from g's closed form in long double (the reference)."""
    w, k = np.clongdouble(w), np.arange(size, dtype=np.longdouble)
    u = -np.expm1(w)
    return np.real(np.clongdouble(c) * (k + 2.0 * (1.0 - u) * (k * u + np.expm1(k * w)) / u**2))


@pytest.mark.parametrize(("c", "s"), [
    (1e-6 * (1 - 0.004j), -0.0015 + 2j * math.pi * 0.56),  # a line narrower than the record resolves
    (2e-6 * (1 - 0.3j), -20.0 + 2j * math.pi * 10.0),  # a broad resonance
    (1e-6 * (1 - 1e-4j), -1e-4 + 2j * math.pi * 0.05),  # slow and narrow: the series and expm1 reach far
    (4e-6, -0.3),  # a GM: real arithmetic
])
def test_consecutive_block_sum_variance_is_block_sum_variance(c, s):
    """At every lag of a long range (a tenth of a 10⁶-sample record's AV factors, ×4), within 1e-13 of the largest
    |S| of the long-double closed form, as block_sum_variance is."""
    size, dt = 400_000, 0.01
    reference = _block_sum_variance_long(c, s * dt, size)
    scale = float(np.max(np.abs(reference)))
    fast = consecutive_block_sum_variance(c, s, size, dt)
    assert fast.shape == (size,)
    assert float(np.max(np.abs(fast - reference))) < 1e-13 * scale
    assert np.allclose(fast, block_sum_variance(c, s, np.arange(size, dtype=float), dt), rtol=0, atol=1e-13 * scale)
