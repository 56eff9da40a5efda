"""The exact likelihood of block sums (core/estimation/block_sums.py) against independent constructions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import toeplitz
from scipy.stats import multivariate_normal

from imu_noise_id.core.errors import InputError
from imu_noise_id.core.estimation.em import block_sums as bs
from imu_noise_id.core.noise.components import GM, QN, RR, RW, WN, simulate_sum
from imu_noise_id.core.noise.flicker import BI
from imu_noise_id.core.noise.resonant import LPF

DT = 0.01


def _brute_force_covariance(sample_covariance: np.ndarray, block: int, blocks: int) -> np.ndarray:
    """Cov of D_k = (block sum k+1) − (block sum k), k = 0 … blocks − 2, from the samples' covariance matrix."""
    a = np.zeros((blocks - 1, block * blocks))
    for k in range(blocks - 1):
        a[k, (k + 1) * block:(k + 2) * block] = 1.0
        a[k, k * block:(k + 1) * block] = -1.0
    return a @ sample_covariance @ a.T


def _sample_covariances(block: int, blocks: int) -> dict[str, tuple[list, np.ndarray]]:
    """Covariance matrices of n samples of each component, built from its definition (not from sum_covariance)."""
    n = block * blocks
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    gm = GM(tau=0.05, sigma=2.0)
    phi = math.exp(-DT / gm.tau)
    walk = RW(0.3)
    s2_rw = walk.random_walk**2 * DT
    qn = QN(1e-3)
    s2_eps = qn.Q**2 / DT**2  # y_t = (ε_t − ε_{t−1})/dt with var(ε/dt) = Q²/dt²
    return {
        "WN": ([WN(0.2)], np.eye(n) * 0.2**2 / DT),
        "GM": ([gm], gm.sigma**2 * phi ** np.abs(i - j)),
        "RW": ([walk], s2_rw * (np.minimum(i, j) + 1.0)),  # y_t = w_0 + … + w_t
        "QN": ([qn], s2_eps * (2.0 * (i == j) - (np.abs(i - j) == 1))),
    }


@pytest.mark.parametrize("name", ["WN", "GM", "RW", "QN"])
def test_autocovariance_is_that_of_the_block_sums_differences(name):
    block, blocks = 4, 7
    components, cov = _sample_covariances(block, blocks)[name]
    expected = _brute_force_covariance(cov, block, blocks)
    gamma = bs.autocovariance(components, block, DT, blocks - 1)
    assert np.allclose(toeplitz(gamma), expected, rtol=1e-9, atol=1e-12 * np.abs(expected).max())


def test_the_sum_of_components_adds_and_a_ramp_adds_nothing():
    parts = [WN(0.2), GM(tau=0.05, sigma=2.0), RW(0.3)]
    total = bs.autocovariance([*parts, RR(5.0)], 6, DT, 5)
    assert np.allclose(total, sum(bs.autocovariance([c], 6, DT, 5) for c in parts), rtol=1e-12)


def test_toeplitz_loglik_is_the_gaussian_density():
    rng = np.random.default_rng(3)
    gamma = bs.autocovariance([WN(0.2), GM(tau=0.3, sigma=1.0), RW(0.1)], 10, DT, 40)
    x = rng.multivariate_normal(np.zeros(40), toeplitz(gamma))
    assert bs.toeplitz_loglik(gamma, x) == pytest.approx(multivariate_normal(cov=toeplitz(gamma)).logpdf(x),
                                                          rel=1e-10)
    assert bs.toeplitz_loglik(np.array([1.0, 2.0, 0.0]), x[:3]) == -math.inf  # not positive definite


def test_block_sums_of_a_record_with_bias_and_ramp():
    n = 100_003
    y = 5.0 + 0.01 * np.arange(n) + np.random.default_rng(1).standard_normal(n)
    y[17] = np.nan
    sums = bs.block_sums(y, DT)
    assert sums.block == math.ceil(n / bs.MAX_BLOCKS) and sums.d.size == n // sums.block - 1
    assert abs(sums.d.mean()) < 1e-9 and sums.n == n
    with pytest.raises(InputError, match="fewer than"):
        bs.block_sums(np.zeros(bs.MIN_BLOCKS - 1), DT)


def test_fit_maximises_and_recovers_the_long_tau_parameters():
    """Fitted from a start a decade off (flicker high, the walk low), the block sums' maximum lies above the truth's
    likelihood and holds the flicker level (its AV plateau above the white noise's and the walk's over 1.5 decades of
    the blocks' τ); the sensor's low-pass (far faster than a block) is held at its start. (From the other side, the
    walk high and the flicker low, the search stops 3 lower where the walk stands for the flicker: the likelihood of
    255 block sums has that second maximum, which is why a screen tries several starts.)"""
    n = 400_000
    truth = [WN(2e-4), LPF(noise_density=1e-4, cutoff=5.0), BI(1e-4, 0.2, n * DT), RW(2e-6)]
    y = simulate_sum(truth, n, DT, np.random.default_rng(11))
    sums = bs.block_sums(y, DT)
    start = [WN(2e-3), LPF(noise_density=1e-4, cutoff=5.0), BI(1e-3, 0.2, n * DT), RW(2e-7)]
    ll, fitted = bs.fit(start, sums)
    assert ll >= bs.loglik(truth, sums) - 1e-6 and ll >= bs.loglik(start, sums)
    assert fitted[2].bias_instability == pytest.approx(1e-4, rel=0.35)
    assert fitted[1] == start[1] and fitted[2].tau_min == 0.2  # held; the band is structure, not a parameter


@pytest.mark.parametrize("memory", [0.7, 12.0, 200.0])
def test_toeplitz_gradient_is_the_trace_formula_written_out(memory):
    # ½ tr[(Σ⁻¹xxᵀΣ⁻¹ − Σ⁻¹) T_h] with Σ⁻¹ formed densely and T_h summed entry by entry, and ℓ against scipy's
    # Gaussian density; the long memory makes Σ ill-conditioned (cond ~ 1e5)
    rng = np.random.default_rng(3)
    m = 60
    gamma = np.exp(-np.arange(m) / memory)
    gamma[0] += 1e-4
    cov = toeplitz(gamma)
    x = rng.multivariate_normal(np.zeros(m), cov)
    ll, grad = bs.toeplitz_loglik_and_gradient(gamma, x)
    assert ll == pytest.approx(multivariate_normal(cov=cov).logpdf(x), rel=1e-10)
    inverse = np.linalg.inv(cov)
    a = np.outer(inverse @ x, inverse @ x) - inverse
    expected = [0.5 * sum(a[i, j] for i in range(m) for j in range(m) if abs(i - j) == h) for h in range(m)]
    assert grad == pytest.approx(expected, rel=1e-7, abs=1e-9 * np.abs(expected).max())
    assert bs.toeplitz_loglik_and_gradient(np.array([1.0, 2.0, 0.0]), x[:3]) is None  # not positive definite
