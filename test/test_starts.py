"""The Allan-variance fit of starting values: its analytic Jacobian against finite differences, and what it finds."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import approx_fprime

from imu_noise_id.core.allan import allan_variance
from imu_noise_id.core.estimation.em.starts import _Curve, _LogAvCurve, fit_allan
from imu_noise_id.core.noise.components import BI, GM, LPF, MA, OSC, QN, RR, RW, WN, simulate_sum
from imu_noise_id.core.noise.flicker import band_for_record

DT = 0.01


@pytest.fixture(scope="module")
def curve() -> _Curve:
    y = simulate_sum([WN(2e-3), GM(tau=2.0, sigma=3e-3), RW(3e-4)], 40_000, DT, np.random.default_rng(3))
    return _Curve.of(allan_variance(y, DT))


def test_the_jacobian_is_that_of_the_log_av_misfit(curve):
    start = [WN(1e-3), QN(1e-5), MA(5e-4), LPF(noise_density=1e-3, cutoff=8.0), BI(2e-4, *band_for_record(40_000, DT)),
             GM(tau=1.5, sigma=2e-3), OSC(5.0, 0.3, 1e-3), RW(2e-4), RR(0.0)]
    keys = [(i, k) for i, c in enumerate(start) if not isinstance(c, RR) for k in c.parameter_names
            if not (isinstance(c, OSC) and k in ("frequency", "bandwidth"))]
    misfit = _LogAvCurve(start, keys, curve, DT)
    x = np.log([start[i].params()[k] for i, k in keys]) + 0.3
    numeric = np.column_stack([approx_fprime(x, lambda v, j=j: misfit.residuals(v)[j], 1e-7)
                               for j in range(curve.tau.size)]).T
    assert misfit.jacobian(x) == pytest.approx(numeric, rel=1e-4, abs=1e-4 * np.abs(numeric).max())
    # the residuals follow the components built from x
    total = sum(c.allan_variance(curve.tau, DT) for c in misfit.build(x) if not isinstance(c, RR))
    assert misfit.residuals(x) == pytest.approx((np.log(total) - np.log(curve.avar)) * np.sqrt(curve.n_clusters))


def test_the_av_fit_starts_near_the_truth(curve):
    class Av:  # one column of an AllanResult, as fit_allan reads it
        tau, m, n = curve.tau, np.round(curve.n / curve.n_clusters), curve.n
        variance = curve.avar[:, None]

    best = {c.name: c for c in fit_allan(["WN", "GM", "RW"], Av, DT)[0][1]}
    assert best["WN"].noise_density == pytest.approx(2e-3, rel=0.1)
    assert best["GM"].tau == pytest.approx(2.0, rel=0.5)
    assert best["GM"].sigma == pytest.approx(3e-3, rel=0.3)
