"""The maximum of the step scan beyond Bonferroni (core/diagnostics/scan_tail.py) against Monte Carlo."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from imu_noise_id.core.diagnostics import detectors as det
from imu_noise_id.core.diagnostics.scan_tail import StepScanTail, overshoot, scan_max_sf
from imu_noise_id.core.diagnostics.whitening import WhiteningFilter
from imu_noise_id.core.noise.components import GM, RW, WN

DT = 0.005


def test_overshoot_limits():
    """ν(0) = 1 (a continuous scan) and ν(x) → 2/x² (far apart positions: Bonferroni's per-position tail)."""
    assert overshoot(np.array([0.0]))[0] == 1.0
    assert overshoot(np.array([1e-4]))[0] == pytest.approx(1.0, abs=1e-3)
    assert overshoot(np.array([40.0]))[0] == pytest.approx(2.0 / 40.0**2, rel=0.01)


def test_independent_positions_give_bonferroni():
    """Uncorrelated neighbours (ρ = 0): the tail is Bonferroni's over the positions (to its union bound)."""
    rho = np.zeros(999)
    b = 4.0
    assert scan_max_sf(b, rho) == pytest.approx(2.0 * 1000 * stats.norm.sf(b), rel=0.05)


@pytest.mark.parametrize("model", [[WN(1.7e-4), RW(2e-5)], [WN(1.7e-4), GM(tau=30.0, sigma=4e-5), RW(2e-5)],
                                   [WN(1.7e-4)]], ids=["WN+RW", "WN+GM+RW", "WN"])
def test_threshold_holds_its_level_on_white_innovations(model):
    """Under the reference model the innovations are white: max_k |T_k| exceeds the tail's level-α threshold in about
    α of 1200 records (binomial sd 0.6 % at α = 0.05; the approximation may be a little conservative), where
    Bonferroni's threshold is exceeded far less often (it pays for 4000 positions as if they were independent)."""
    n, sims, alpha = 4000, 1200, 0.05
    whitening = WhiteningFilter.from_components(model, DT)
    m = max(20, n // 200)
    tail = StepScanTail.of(whitening, n, m)
    rng = np.random.default_rng(3)
    largest = np.array([np.nanmax(np.abs(det.step_scan(rng.standard_normal(n), whitening, m)))
                        for _ in range(sims)])
    rate = float(np.mean(largest > tail.threshold(alpha)))
    assert 0.032 < rate < 0.065, rate
    bonferroni = float(np.mean(largest > stats.norm.isf(alpha / (2 * (n - 2 * m)))))
    assert bonferroni < 0.6 * rate, (bonferroni, rate)


def test_detect_step_with_the_tail_finds_a_step_bonferroni_misses():
    """A step of 4.8 standard errors beside a random walk: the correlated tail calls it at α = 0.001, Bonferroni over
    positions does not; a scan given the tail of another length is refused."""
    n = 24000
    model = [WN(1.7e-4), RW(2e-5)]
    whitening = WhiteningFilter.from_components(model, DT)
    m = max(20, n // 200)
    tail = StepScanTail.of(whitening, n, m)
    ones, step = whitening.whiten(np.ones(n)), whitening.whiten((np.arange(n) >= n // 2).astype(float))
    residual = step - ones * float(ones @ step) / float(ones @ ones)
    size = 4.8 / float(np.sqrt(residual @ residual))  # in units of the innovations' sd
    e = size * step  # noiseless: T at the step's sample is 4.8 exactly
    with_tail = det.detect_step(e, DT, whitening, alpha=1e-3, min_segment=m, tail=tail)
    plain = det.detect_step(e, DT, whitening, alpha=1e-3, min_segment=m)
    assert with_tail.significant and not plain.significant
    assert abs(with_tail.params["index"] - n // 2) <= 1
    with pytest.raises(ValueError, match="tail of"):
        det.detect_step(e[:-100], DT, whitening, alpha=1e-3, min_segment=m, tail=tail)
