"""The Whittle likelihood's spectra (core.estimation.whittle): a state-space block's spectral density per sample
against the Fourier sum of its autocovariance, written out independently of the code under test."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import solve_discrete_lyapunov

from imu_noise_id.core.estimation.whittle import block_spectrum
from imu_noise_id.core.noise.components import LPF, MA, OSC
from imu_noise_id.core.noise.flicker import BI

DT = 0.01


def _spectrum_from_autocovariance(phi, q, h, omega, lags=4000):
    """S(ω) = R(0) + 2 Σ_{j≥1} R(j) cos(ωj), R(j) = h Φ^j P hᵀ, P the stationary covariance."""
    p = solve_discrete_lyapunov(phi, q)
    r, x = [], p @ h
    for _ in range(lags):
        r.append(h @ x)
        x = phi @ x
    r = np.array(r)
    j = np.arange(1, lags)
    return r[0] + 2.0 * np.cos(np.outer(omega, j)) @ r[1:]


@pytest.mark.parametrize("component", [OSC(3.0, 0.6, 1e-3), OSC(20.0, 8.0, 2e-3), MA(1e-3), LPF(1e-3, 20.0),
                                       BI(3e-4, 0.05, 2.0)], ids=str)
def test_block_spectrum_is_the_fourier_sum_of_the_autocovariance(component):
    blk = component.block(DT)
    omega = np.linspace(0.01, np.pi, 57)
    assert block_spectrum(blk.phi, blk.q, blk.h, omega) == pytest.approx(
        _spectrum_from_autocovariance(blk.phi, blk.q, blk.h, omega), rel=1e-6)


def test_a_block_larger_than_two_by_two_is_solved_per_frequency():
    phi = np.array([[0.5, 0.2, 0.0], [-0.1, 0.6, 0.1], [0.0, 0.05, 0.3]])
    q, h = np.diag([1.0, 0.5, 0.2]), np.array([1.0, 0.0, 1.0])
    omega = np.linspace(0.01, np.pi, 31)
    assert block_spectrum(phi, q, h, omega) == pytest.approx(_spectrum_from_autocovariance(phi, q, h, omega), rel=1e-9)
