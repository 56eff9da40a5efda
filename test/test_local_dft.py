"""The Fourier sum near one frequency from block moments (core/diagnostics/local_dft.py) against the direct sum."""

from __future__ import annotations

import numpy as np
import pytest

from imu_noise_id.core.diagnostics.local_dft import LocalDft

DT = 0.01


@pytest.mark.parametrize("n", [999, 200_003])
def test_it_is_the_direct_sum_within_its_reach(n):
    rng = np.random.default_rng(3)
    t = np.arange(n) * DT
    x = rng.standard_normal(n) + 0.05 * np.sin(2 * np.pi * 1.2345678 * t)
    x[:7] = np.nan  # missing samples count as 0
    local = LocalDft.of(x, DT, 1.2345)
    bin_width = 1.0 / (n * DT)
    assert local.reach >= 1.4 * bin_width  # a line's ±1 bin from the centre of its two bins
    filled = np.nan_to_num(x)
    farthest = min(0.999 * local.reach, 3.0 * bin_width)
    for f in (1.2345, 1.2345 + 0.7 * bin_width, 1.2345 - 1.3 * bin_width, 1.2345 + farthest):
        direct = np.sum(filled * np.exp(-2j * np.pi * f * t))
        assert abs(local.at(f) - direct) <= 1e-10 * np.sum(np.abs(filled))


def test_it_refuses_a_frequency_beyond_its_reach():
    local = LocalDft.of(np.ones(100_000), DT, 2.0)
    with pytest.raises(ValueError, match="beyond the reach"):
        local.at(2.0 + 2.0 * local.reach)
