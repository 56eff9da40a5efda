"""The one χ² bound of the normalised innovation squared, and that every consistency check uses it."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from imu_noise_id.core.diagnostics.consistency import nis_bounds
from imu_noise_id.core.diagnostics.monitor import InnovationMonitor
from imu_noise_id.pipelines.cmkf_replay import nis_summary


def test_nis_bounds_are_the_chi2_quantiles_of_the_mean():
    assert nis_bounds(3) == (chi2.ppf(0.025, 3), chi2.ppf(0.975, 3))
    low, high = nis_bounds(3, 50)
    assert (low, high) == pytest.approx((chi2.ppf(0.025, 150) / 50, chi2.ppf(0.975, 150) / 50), rel=1e-15)
    assert low < 3 < high
    # the mean of many values is pinned closer to dof; a smaller alpha widens the interval
    assert nis_bounds(3, 500)[1] - nis_bounds(3, 500)[0] < high - low
    assert nis_bounds(1, 100, 1e-3)[0] < nis_bounds(1, 100)[0]
    for bad in ((0, 1, 0.05), (3, 0, 0.05), (3, 1, 0.0), (3, 1, 1.0)):
        with pytest.raises(ValueError):
            nis_bounds(*bad)


def test_monitor_and_replay_summary_use_the_same_bounds():
    rng = np.random.default_rng(0)
    monitor = InnovationMonitor(200, 5, alpha=0.01)
    for x in rng.standard_normal(200):
        monitor.update(x, 1.0)
    assert monitor.status().nis_interval == nis_bounds(1, 200, 0.01)
    nis = chi2.rvs(3, size=1000, random_state=1)
    low, high = nis_bounds(3)
    tail = nis[200:]
    assert nis_summary(nis, 3)["share_in_95"] == np.mean((tail >= low) & (tail <= high))
