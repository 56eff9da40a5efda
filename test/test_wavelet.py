"""Haar wavelet variance: the estimator, its relation to the Allan variance, the theoretical WV of every component,
the model-based covariance of the estimates and the robust (M-estimator) version."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from imu_noise_id.core.allan import allan_variance
from imu_noise_id.core.errors import InputError
from imu_noise_id.core.noise.components import BI, GM, MA, QN, RR, RW, WN, simulate_sum
from imu_noise_id.core.noise.digital import DLPF
from imu_noise_id.core.noise.resonant import LPF, OSC
from imu_noise_id.core.wavelet import covariance as cv
from imu_noise_id.core.wavelet.robust import BiweightScale
from imu_noise_id.core.wavelet.variance import dyadic_m, wavelet_variance

DT = 0.01


def _modwt_haar_direct(y: np.ndarray, m: int) -> np.ndarray:
    """Level coefficients by direct convolution with the MODWT Haar filter h = (+1/2m … , −1/2m …) (an independent
    implementation: no phase, no cumulative sums); only those that do not touch the ends."""
    h = np.concatenate([np.full(m, 1.0 / (2 * m)), np.full(m, -1.0 / (2 * m))])
    return np.convolve(y, h, mode="valid")


def test_classical_wv_is_the_mean_square_of_modwt_coefficients_and_half_the_allan_variance():
    y = simulate_sum([WN(1e-3), RW(1e-4), GM(0.3, 2e-3)], 5000, DT, np.random.default_rng(3))
    wv = wavelet_variance(y, DT)
    np.testing.assert_array_equal(wv.m, dyadic_m(y.size))
    direct = [np.mean(_modwt_haar_direct(y, int(m)) ** 2) for m in wv.m]
    np.testing.assert_allclose(wv.nu2, direct, rtol=1e-9)
    av = allan_variance(y, DT, m=wv.m)
    np.testing.assert_allclose(wv.nu2, av.variance[:, 0] / 2, rtol=1e-12)
    assert np.all(wv.ci_low < wv.nu2) and np.all(wv.nu2 < wv.ci_high)
    assert wv.n_coefficients[0] == y.size - 1


def test_wv_refuses_bad_input():
    with pytest.raises(InputError, match="one axis"):
        wavelet_variance(np.zeros((100, 2)), DT)
    with pytest.raises(InputError, match="scales"):
        wavelet_variance(np.random.default_rng(0).standard_normal(20), DT)
    with pytest.raises(InputError, match="constant"):
        wavelet_variance(np.ones(1000), DT)


def _mc_wv(comps, n, reps, seed, scale=None):
    """WV estimates of ``reps`` independent n-sample records (consecutive chunks of one simulation: the WV does not
    see a record's offset), by direct convolution; robust with ``scale``."""
    y = simulate_sum(comps, n * reps, DT, np.random.default_rng(seed)).reshape(reps, n)
    m = dyadic_m(n)
    est = np.empty((reps, m.size))
    for r in range(reps):
        for j, mm in enumerate(m):
            w = _modwt_haar_direct(y[r], int(mm))
            est[r, j] = np.mean(w * w) if scale is None else scale.solve(w)
    return m, est


@pytest.mark.parametrize("component", [
    WN(1e-3), QN(2e-5), RW(5e-4), GM(0.2, 1e-3), GM(0.01, 1e-3), RR(2e-3), LPF(1e-3, 15.0), OSC(4.0, 0.8, 1e-3),
    MA(1e-3), BI(3e-4, 0.1, 10.0),
], ids=str)
def test_theoretical_wv_of_every_component_matches_simulation(component):
    """Mean WV of 400 simulated records against ν(θ) = AV/2 of the sampled process, within 4 standard errors."""
    comps = [WN(1e-7), component]
    m, est = _mc_wv(comps, 1024, 400, seed=11)
    theory = cv.theoretical_wv(comps, m * DT, DT)
    se = est.std(axis=0, ddof=1) / np.sqrt(est.shape[0])
    if isinstance(component, RR):  # deterministic: every record has the same WV up to the tiny white noise
        np.testing.assert_allclose(est.mean(axis=0), theory, rtol=1e-3)
    else:
        assert np.all(np.abs(est.mean(axis=0) - theory) < 4 * se + 1e-12 * theory), (est.mean(axis=0) / theory)


def _brute_covariance(comps, m, n):
    """Cov of the classical WV estimates of a Gaussian model by the exact lag sum over every integer lag."""
    out = np.empty((m.size, m.size))
    k = np.arange(-(n - 1), n)
    for i, mi in enumerate(m):
        for j, mj in enumerate(m):
            g = sum(cv._C[a] * cv._C[b] * sum(c.sum_covariance(k + a * mi - b * mj, DT) for c in comps)
                    for a in range(3) for b in range(3)) / (4.0 * mi * mj)
            pairs = cv._pair_counts(k, int(mi), int(mj), n)
            out[i, j] = 2 * np.sum(pairs * g**2) / ((n - 2 * mi + 1) * (n - 2 * mj + 1))
    return out


@pytest.mark.parametrize("comps", [[WN(1e-3), RW(1e-4)], [WN(1e-3), GM(0.3, 1e-3), RW(1e-4)], [QN(1e-5), WN(1e-3)],
                                   [WN(1e-3), OSC(5.0, 0.5, 1e-3)], [WN(1e-3), MA(1e-3), BI(2e-4, 0.1, 10.0)],
                                   [WN(1e-5), DLPF(8.8e-4, 37.0, 2), GM(10.0, 4e-4), RW(3e-5)],
                                   [WN(1e-5), DLPF(8.8e-4, 37.0, 2), OSC(31.0, 0.2, 1e-3), GM(10.0, 4e-4)],
                                   [WN(1e-3), DLPF(8.8e-4, 37.0, 2), OSC(0.56, 0.002, 5e-3), RW(1e-4)]],
                         ids=lambda c: "+".join(x.name for x in c))
def test_covariance_lag_grid_equals_the_exact_lag_sum(comps):
    n = 1 << 12
    m = dyadic_m(n)
    exact = _brute_covariance(comps, m, n)
    grid = cv.wv_covariance(comps, m, n, DT)
    scale = np.sqrt(np.outer(np.diag(exact), np.diag(exact)))
    assert np.max(np.abs(grid - exact) / scale) < 1e-3


class _CountedLags(WN):
    """A white noise that counts the lags its partial sums' covariance is evaluated at."""

    lags = 0

    def sum_covariance(self, u, dt):
        _CountedLags.lags += np.size(u)
        return super().sum_covariance(u, dt)


def test_a_low_pass_beside_a_slow_process_does_not_take_every_lag_of_the_record():
    """A second-order low-pass (poles of a 2.5-sample period, a memory of two samples) beside a GM of τ 10 s: the
    grid took every lag of the record for every pair of scales, the low-pass's period setting the step also where its
    oscillation had long died out (98 s per evaluation on 30 min at 100 Hz, GMWM with such candidates minutes per
    axis). The period now sets the step only within the oscillation's own decay around each kink; the lag sum is
    still the exact one to 1e-3 (test above). Each oscillating component sets the step within its own decay: a slow
    narrow line's step over the record, the low-pass's near the kinks."""
    n = 1 << 12
    m = dyadic_m(n)
    every = sum(2 * n - 1 for i in range(m.size) for _ in range(i, m.size)) * 9
    counted = _CountedLags(1e-5)
    _CountedLags.lags = 0
    cv.wv_covariance([counted, DLPF(8.8e-4, 37.0, 2), GM(10.0, 4e-4), RW(3e-5)], m, n, DT)
    assert _CountedLags.lags < 0.2 * every
    # a line of long memory keeps its oscillation over the whole record, and the fine step there
    _CountedLags.lags = 0
    cv.wv_covariance([counted, OSC(31.0, 0.02, 1e-3), GM(10.0, 4e-4)], m, n, DT)
    assert _CountedLags.lags > 0.5 * every
    # a slow narrow line (a measured accelerometer's 0.56 Hz) is followed at its own step, the low-pass near the kinks
    _CountedLags.lags = 0
    cv.wv_covariance([counted, DLPF(8.8e-4, 37.0, 2), OSC(0.56, 0.002, 5e-3), RW(1e-4)], m, n, DT)
    assert _CountedLags.lags < 0.25 * every


def test_a_line_of_long_memory_is_summed_in_bounded_memory(monkeypatch):
    """A narrow line keeps its oscillation over the whole record, so every lag of every pair of scales is taken: all
    pairs' lags were held at once, ten arrays of them (24 GB killed a GMWM fit with a 20 Hz line on 10⁶ samples). The
    lag sum now runs over groups of pairs of at most CHUNK_POINTS lags (one pair's at least), plans kept up to
    CACHE_POINTS lags: the same covariance, the working memory bounded by the two, not by the record times the
    pairs."""
    n = 1 << 13
    m = dyadic_m(n)
    comps = [WN(1e-3), OSC(31.0, 0.02, 1e-3)]
    whole = cv.wv_covariance(comps, m, n, DT)
    monkeypatch.setattr(cv, "CHUNK_POINTS", 1 << 14)
    monkeypatch.setattr(cv, "CACHE_POINTS", 1 << 14)
    tracemalloc.start()
    try:
        chunked = cv.wv_covariance(comps, m, n, DT)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    np.testing.assert_allclose(chunked, whole, rtol=1e-12)
    every = sum(2 * n - 1 for i in range(m.size) for _ in range(i, m.size))
    assert peak < 2 * every * 8  # all pairs' lags at once take ten arrays of ``every`` float64


@pytest.mark.parametrize("frequency", [0.46, 0.56, 1.69, 10.0, 20.0, 49.0])
def test_the_narrowest_line_rings_within_the_bound_and_not_far_inside_it(frequency):
    """A line at its narrowest bandwidth rings over at most MAX_RING_LAGS lags per kink (the GMWM's box keeps its
    OSCs there: a measured accelerometer's 0.56 Hz line, 0.0008 Hz wide, made each covariance take a minute), and a
    line a quarter as wide would not."""
    n, dt = 1_000_000, 0.01
    narrowest = cv.narrowest_line(frequency, n, dt)
    ring, step = cv._ring(OSC(frequency, narrowest, 1e-3), n, dt)
    assert 2 * ring / max(1, int(step)) <= cv.MAX_RING_LAGS
    ring, step = cv._ring(OSC(frequency, narrowest / 4, 1e-3), n, dt)
    assert 2 * ring / max(1, int(step)) > cv.MAX_RING_LAGS
    assert cv.narrowest_line(frequency, 1000, dt) == 0.0  # a short record: every lag is within the bound


def test_covariance_matches_monte_carlo_classical_and_robust():
    """V(θ) against the covariance of 400 simulated WV estimates (WN+GM+RW), classical and robust."""
    comps = [WN(1e-3), GM(0.2, 2e-3), RW(3e-4)]
    n, reps = 2048, 400
    for scale in (None, BiweightScale.for_efficiency(0.6)):
        m, est = _mc_wv(comps, n, reps, seed=5, scale=scale)
        model = cv.wv_covariance(comps, m, n, DT, scale=scale)
        mc = np.cov(est.T)
        ratio = np.diag(mc) / np.diag(model)
        # 400 draws: the variance of a variance estimate is known to about ±15 % (two se); the longest scales of
        # the robust estimator carry its small-sample bias, so only the others are held to it there.
        held = slice(None) if scale is None else slice(0, -2)
        assert np.all(np.abs(ratio[held] - 1) < 0.25), ratio
        corr = lambda a: a / np.sqrt(np.outer(np.diag(a), np.diag(a)))  # noqa: E731
        assert np.max(np.abs(corr(mc) - corr(model))[held, held]) < 0.15


def test_robust_scale_has_the_asked_efficiency_and_is_consistent():
    scale = BiweightScale.for_efficiency(0.6)
    assert scale.efficiency == pytest.approx(0.6, abs=1e-6)
    assert sum(scale.hermite) == pytest.approx(scale.e**2 / (2 * scale.efficiency), rel=1e-6)
    assert scale.hermite[0] == pytest.approx(scale.e**2 / 2, rel=1e-6)  # a_2 = e (Stein)
    rng = np.random.default_rng(0)
    est = np.array([scale.solve(3.0 * rng.standard_normal(5000)) for _ in range(300)])
    assert est.mean() == pytest.approx(9.0, rel=0.01)
    # Variance against the classical 2σ⁴/n divided by the efficiency.
    assert est.var() * 5000 / (2 * 81) == pytest.approx(1 / 0.6, rel=0.2)


def test_robust_wv_resists_outliers_where_the_classical_breaks():
    comps = [WN(1e-3), RW(2e-4)]
    rng = np.random.default_rng(8)
    y = simulate_sum(comps, 1 << 15, DT, rng)
    clean_rob = wavelet_variance(y, DT, robust=True)
    dirty = y.copy()
    idx = rng.choice(y.size, size=y.size // 100, replace=False)  # 1 % outliers of 15 × the white-noise sd
    dirty[idx] += rng.choice([-1, 1], idx.size) * 15 * WN(1e-3).per_sample(DT)["sigma2_wn"] ** 0.5
    classical = wavelet_variance(dirty, DT)
    robust = wavelet_variance(dirty, DT, robust=True)
    theory = cv.theoretical_wv(comps, classical.tau, DT)
    assert classical.nu2[0] > 2.5 * theory[0]  # the plain estimate breaks at the short scales
    # Where an outlier moves its coefficients far beyond the robust estimator's cut-off c·ν (the three shortest
    # scales here) the robust WV stays inside the clean record's intervals; at longer scales the outliers are spread
    # over most windows, move each coefficient by little, and act as added white noise, which no scale-wise
    # estimator can tell from the signal (docs/gmwm.md).
    inside = (robust.nu2 > clean_rob.ci_low) & (robust.nu2 < clean_rob.ci_high)
    assert inside[:3].all(), robust.nu2 / clean_rob.nu2
