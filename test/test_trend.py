"""Least-squares slope and its exact variance under a noise model (core.noise.trend, eq. 1)."""

from __future__ import annotations

import numpy as np
import pytest

from imu_noise_id.core.noise.components import GM, LPF, MA, OSC, QN, RR, RW, WN, simulate_sum
from imu_noise_id.core.noise.trend import ls_slope, ls_slope_variance

N, DT = 300, 0.5
IDX = np.arange(N)
W = (IDX - IDX.mean()) / ((IDX - IDX.mean()) @ (IDX - IDX.mean())) / DT  # the slope's weights


@pytest.mark.parametrize("component, covariance", [
    (WN(0.3), WN(0.3).per_sample(DT)["sigma2_wn"] * np.eye(N)),
    (GM(tau=20.0, sigma=0.5), 0.25 * np.exp(-DT / 20.0) ** np.abs(IDX[:, None] - IDX[None, :])),
    (RW(0.01), 0.01**2 * DT * np.minimum(IDX[:, None], IDX[None, :]) + 0.01**2 * DT),
])
def test_slope_variance_equals_the_quadratic_form_of_the_covariance(component, covariance):
    assert ls_slope_variance([component], N, DT) == pytest.approx(W @ covariance @ W, rel=1e-9)


def test_slope_variance_of_a_sum_matches_simulation_and_ignores_the_ramp():
    comps = [WN(0.3), QN(0.4), GM(tau=20.0, sigma=0.5), RW(0.01)]
    rng = np.random.default_rng(3)
    slopes = [ls_slope(simulate_sum([*comps, RR(0.2)], N, DT, rng), DT) for _ in range(8000)]
    expected = ls_slope_variance(comps, N, DT)
    assert ls_slope_variance([*comps, RR(0.2)], N, DT) == expected
    assert np.var(slopes) == pytest.approx(expected, rel=0.05)  # 8000 draws: relative sd of the variance 1.6 %
    assert np.mean(slopes) == pytest.approx(0.2, abs=4 * np.sqrt(expected / 8000))


def test_ls_slope_skips_missing_samples():
    y = 3.0 + 0.25 * DT * IDX
    y[[5, 6, 100]] = np.nan
    assert ls_slope(y, DT) == pytest.approx(0.25)


@pytest.mark.parametrize("component", [LPF(noise_density=2e-3, cutoff=15.0),
                                       OSC(frequency=7.0, bandwidth=0.3, sigma=0.01), MA(1e-3)],
                         ids=lambda c: c.name)
def test_slope_variance_tail_in_closed_form_equals_the_full_lag_sum(component):
    n, dt = 200_000, 0.01
    lags = np.arange(1, n, dtype=float)
    full = float(lags @ component.sum_covariance(lags, dt))
    k_n = float(component.sum_covariance(np.array([float(n)]), dt)[0])
    mid, alpha = 0.5 * (n - 1), 12.0 / (dt * n * (n * n - 1.0))
    exact = alpha**2 * (-2.0 * full + 2.0 * mid * mid * k_n)  # K(0) = 0 for these components
    assert float(component.sum_covariance(np.zeros(1), dt)[0]) == 0.0
    assert ls_slope_variance([component], n, dt) == pytest.approx(exact, rel=1e-9)
