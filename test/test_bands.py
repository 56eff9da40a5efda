"""The thinned Allan variance the simulated band is drawn with, against the fully overlapping estimator."""

from __future__ import annotations

import numpy as np

from imu_noise_id.core.allan import allan_variance
from imu_noise_id.core.simulation.bands import TERMS_PER_FACTOR, thinned_allan_variance


def test_short_factors_are_the_full_estimator():
    y = np.random.default_rng(1).standard_normal(5000) + 3.0
    m = np.arange(1, 2 * TERMS_PER_FACTOR)
    np.testing.assert_allclose(thinned_allan_variance(y, 0.01, m), allan_variance(y, 0.01, m=m).variance[:, 0],
                               rtol=1e-12)


def test_long_factors_keep_the_full_estimators_mean_and_spread():
    """300 white-noise records of 10⁵ samples: at m = 64 … 4096 the thinned estimator's mean and relative spread are
    within 3 % and 10 % of the fully overlapping one's (and it differs from it: terms are left out)."""
    rng = np.random.default_rng(2)
    m = np.array([64, 256, 1024, 4096])
    full, thin = [], []
    for _ in range(300):
        y = rng.standard_normal(100_000)
        full.append(allan_variance(y, 1.0, m=m).variance[:, 0])
        thin.append(thinned_allan_variance(y, 1.0, m))
    full, thin = np.array(full), np.array(thin)
    assert not np.allclose(full, thin)
    np.testing.assert_allclose(thin.mean(axis=0), full.mean(axis=0), rtol=0.03)
    np.testing.assert_allclose(thin.std(axis=0) / thin.mean(axis=0), full.std(axis=0) / full.mean(axis=0), rtol=0.10)
