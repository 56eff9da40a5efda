"""The WN+RW overbound (issue 13): above the bound at every τ, and as small as that allows."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog

from imu_noise_id.core.errors import InputError
from imu_noise_id.core.estimation.overbound import overbound_wn_rw
from imu_noise_id.core.noise.components import GM, RW, WN, total_allan_variance

DT = 0.01
TAU = DT * np.unique(np.round(np.logspace(0, 4, 33)).astype(int))  # 0.01 … 100 s, log grid


def _bound(components, inflate=1.0):
    return inflate * total_allan_variance(components, TAU, DT)


@pytest.mark.parametrize("components", [
    [WN(1.7e-4), GM(30.0, 3e-4), RW(2e-5)],   # a bias-instability bump WN+RW cannot follow
    [WN(2e-3), GM(5.0, 1e-3)],                # no random walk at all
    [WN(1e-3), RW(1e-3)],                     # random walk dominant from 3 s on
])
def test_above_the_bound_everywhere_and_as_small_as_that_allows(components):
    bound = _bound(components)
    ob = overbound_wn_rw(TAU, bound, DT)
    av = ob.allan_variance(TAU, DT)
    assert np.all(av >= bound * (1 - 1e-12))  # above the bound at every τ of the range
    # optimal: scipy's LP (HiGHS), an independent solver of the same programme, finds no smaller objective
    G = np.column_stack([WN(1.0).allan_variance(TAU, DT), RW(1.0).allan_variance(TAU, DT)])
    A = G / bound[:, None]  # rows scaled to "≥ 1" and columns to O(1): HiGHS' tolerances are absolute
    scale = 1.0 / A.max(axis=0)
    lp = linprog(c=(A * scale).sum(axis=0), A_ub=-(A * scale), b_ub=-np.ones(len(TAU)),
                 bounds=[(0, None), (0, None)], method="highs")
    assert lp.status == 0
    assert ob.mean_ratio * len(TAU) == pytest.approx(lp.fun, rel=1e-7)
    # minimal: lowering either number that is not already 0 breaks the bound at some τ
    if ob.noise_density > 0:
        lower = WN(ob.noise_density * (1 - 1e-4)).allan_variance(TAU, DT) + RW(ob.random_walk).allan_variance(TAU, DT)
        assert np.any(lower < bound)
    if ob.random_walk > 0:
        lower = WN(ob.noise_density).allan_variance(TAU, DT) + RW(ob.random_walk * (1 - 1e-4)).allan_variance(TAU, DT)
        assert np.any(lower < bound)
    assert ob.binding_tau and all(t in TAU for t in ob.binding_tau)


def test_a_bound_that_is_a_wn_rw_is_returned_exactly():
    bound = _bound([WN(1.7e-4), RW(2e-5)])
    ob = overbound_wn_rw(TAU, bound, DT)
    assert ob.noise_density == pytest.approx(1.7e-4, rel=1e-9)
    assert ob.random_walk == pytest.approx(2e-5, rel=1e-9)
    assert ob.mean_ratio == pytest.approx(1.0, rel=1e-9)


def test_white_noise_alone_when_the_bound_falls_like_it():
    bound = _bound([WN(1e-3)], inflate=1.3)
    ob = overbound_wn_rw(TAU, bound, DT)
    assert ob.random_walk < 1e-9 and ob.noise_density == pytest.approx(1e-3 * np.sqrt(1.3), rel=1e-9)


def test_bad_bounds_are_refused():
    with pytest.raises(InputError, match="at least one"):
        overbound_wn_rw(np.array([]), np.array([]), DT)
    with pytest.raises(InputError, match="positive, finite"):
        overbound_wn_rw(TAU, np.where(TAU > 1, np.nan, 1.0), DT)


def test_floors_keep_the_fitted_values_and_bind_when_the_range_is_short():
    """Over 0.01–1 s a random walk of 2e-5 is invisible: without a floor K would drop to 0; with the fitted values
    as floors K stays at them (reported as at its floor) and the bound still holds."""
    short = TAU[TAU <= 1.0]
    bound = WN(1.7e-4).allan_variance(short, DT)  # what the short range sees: white noise only
    free = overbound_wn_rw(short, bound * 1.2, DT)
    assert free.random_walk < 1e-9  # 0 up to the rounding of collinear constraints
    held = overbound_wn_rw(short, bound * 1.2, DT, floor=(1.7e-4, 2e-5))
    assert held.random_walk == pytest.approx(2e-5, rel=1e-12) and held.at_floor == (False, True)
    assert held.noise_density >= 1.7e-4
    assert np.all(held.allan_variance(short, DT) >= bound * 1.2 * (1 - 1e-12))
    lower = WN(held.noise_density * (1 - 1e-4)).allan_variance(short, DT) + RW(2e-5).allan_variance(short, DT)
    assert np.any(lower < bound * 1.2)  # N is as small as the bound allows once K is held
