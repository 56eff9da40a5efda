"""The data's AV band under the model (core/diagnostics/av_band.py) against Monte Carlo and the textbook EDF."""

from __future__ import annotations

import numpy as np
import pytest

from imu_noise_id.core.allan import allan_variance, choose_m, identify_alpha
from imu_noise_id.core.allan.edf import edf_of
from imu_noise_id.core.diagnostics.av_band import model_av_band, model_av_edf, model_av_range
from imu_noise_id.core.diagnostics.residuals import av_misfit_z
from imu_noise_id.core.noise.components import OSC, RR, RW, WN, simulate_sum, total_allan_variance

DT = 0.01


def test_edf_of_white_noise_and_random_walk_agrees_with_greenhall():
    """Where the textbook EDF holds (one power law), the exact one is close to Greenhall's approximation."""
    n = 100_000
    m = choose_m(n, "allan", m_max=n // 10)
    for model, alpha in (([WN(1e-3)], 0), ([RW(1e-4)], -2)):
        ratio = model_av_edf(model, m, n, DT) / np.array([edf_of("allan", alpha, int(k), n) for k in m])
        assert np.all((ratio > 0.8) & (ratio < 1.35)), (model[0].name, ratio)


def test_edf_gives_the_variance_of_the_estimates_monte_carlo():
    """Var(AV_hat) = 2 AV² / EDF at each τ, against 400 simulated records of WN + RW + a 2 Hz line + a ramp
    (sampling error of the Monte-Carlo variance ≈ 10 %)."""
    n, sims = 20_000, 400
    model = [WN(1e-3), RW(2e-4), OSC(frequency=2.0, bandwidth=0.2, sigma=3e-3)]
    ramp = RR(2e-5)
    m = np.array([1, 4, 16, 50, 200, 1000])
    rng = np.random.default_rng(5)
    ramp_y = ramp.slope * DT * np.arange(n)
    est = np.array([allan_variance(simulate_sum(model, n, DT, rng) + ramp_y, DT, m=m).variance[:, 0]
                    for _ in range(sims)])
    edf = model_av_edf([*model, ramp], m, n, DT)
    mean = total_allan_variance([*model, ramp], m * DT, DT)
    np.testing.assert_allclose(est.mean(axis=0), mean, rtol=0.1)
    np.testing.assert_allclose(est.var(axis=0), 2.0 * mean**2 / edf, rtol=0.25)


def test_model_range_holds_the_simulated_avs_at_its_level():
    """The model's 95 % AV range (the figures' band) holds 95 % of 400 simulated records' AVs at each τ (binomial
    sd 1.1 %), its ends on either side of the simulations' median, and it is ordered low < AV < high."""
    n, sims = 20_000, 400
    model = [WN(1e-3), RW(2e-4), OSC(frequency=2.0, bandwidth=0.2, sigma=3e-3)]
    m = np.array([1, 4, 16, 50, 200, 1000, 5000])
    rng = np.random.default_rng(11)
    est = np.array([allan_variance(simulate_sum(model, n, DT, rng), DT, m=m).variance[:, 0] for _ in range(sims)])
    band = model_av_range(model, m, n, DT)
    np.testing.assert_allclose(band.tau, m * DT)
    assert np.all((band.low < band.av) & (band.av < band.high))
    inside = np.mean((est >= band.low) & (est <= band.high), axis=0)
    assert np.all((inside > 0.91) & (inside < 0.985)), inside
    below = np.mean(est < band.low, axis=0)
    assert np.all(below < 0.06), below


def test_band_holds_its_level_where_a_narrow_line_dominates():
    """A correct model of WN + a 0.565 Hz line + a 10.8 Hz vibration (the ADIS16405 accelerometers): with the
    model's EDF the misfit z-scores are N(0, 1) at every τ; with the EDF of the local power-law slope they spread
    5–13× wider at τ = 0.18–1 s, where the line dominates."""
    n = 100_000
    model = [WN(4e-4), OSC(frequency=0.565, bandwidth=0.002, sigma=4.8e-3),
             OSC(frequency=10.8, bandwidth=0.55, sigma=8.8e-3)]
    m = choose_m(n, "allan", m_max=n // 10)
    av_model = total_allan_variance(model, m * DT, DT)
    alpha = identify_alpha(m * DT, av_model[:, None], "allan")
    z_model, z_textbook = [], []
    for seed in range(30):
        av = allan_variance(simulate_sum(model, n, DT, np.random.default_rng(seed)), DT, m=m, alpha=alpha)
        data = av.variance[:, 0]
        z_model.append(av_misfit_z(data, model_av_band(data, model, m, n, DT), av_model))
        z_textbook.append(av_misfit_z(data, (av.ci_low[:, 0], av.ci_high[:, 0]), av_model))
    sd_model, sd_textbook = np.std(z_model, axis=0), np.std(z_textbook, axis=0)
    assert np.all((sd_model > 0.7) & (sd_model < 1.3)), sd_model
    assert np.mean(np.abs(np.array(z_model)) > 1.96) == pytest.approx(0.05, abs=0.03)
    line = (m * DT >= 0.18) & (m * DT <= 1.0)
    assert np.all(sd_textbook[line] > 3.0), sd_textbook[line]


def test_a_flicker_ladder_edf_from_its_unit_scale_memo_equals_the_direct_one(monkeypatch):
    # A loop diagnoses many fits of one ladder: its K at unit scale is computed once and scaled; K and the EDF must be
    # those computed from the component itself, at every scale.
    from imu_noise_id.core.diagnostics import av_band
    from imu_noise_id.core.noise.flicker import BI

    n, dt = 20_000, 0.01
    m = np.array([1, 4, 16, 64, 256, 1024])
    av_band._unit_sum_covariance.cache_clear()
    scales = (1e-4, 3e-3)
    for b in scales:
        ladder = BI(b, tau_min=0.1, tau_max=200.0)
        direct = np.asarray(av_band._computed_sum_covariance(ladder, n + 1, dt))
        assert av_band._sum_covariance(ladder, n + 1, dt) == pytest.approx(direct, rel=1e-12, abs=0.0)
    av_band._unit_sum_covariance.cache_clear()
    memo = {b: model_av_edf([WN(1e-3), BI(b, tau_min=0.1, tau_max=200.0)], m, n, dt) for b in scales}
    assert av_band._unit_sum_covariance.cache_info().currsize == 1  # both scales share the unit ladder
    monkeypatch.setattr(av_band, "_sum_covariance", av_band._computed_sum_covariance)
    for b in scales:
        assert memo[b] == pytest.approx(model_av_edf([WN(1e-3), BI(b, tau_min=0.1, tau_max=200.0)], m, n, dt),
                                        rel=1e-12)


def _brute_force_edf(components: list, m: int, n: int, dt: float) -> float:
    """EDF of the overlapping AV from the autocovariance R(u) alone (no closed forms): d_k's weights w (−1/m on m
    samples, +1/m on the next m), c(l) = Σ_ab w_a w_b R(l + b − a) at every lag, and Var = (1/4M²) Σ_|l|<M (M − |l|)
    2c(l)²."""
    lags = np.arange(n + 2 * m, dtype=float)
    r = np.zeros(lags.size)
    for comp in components:
        s = comp.sum_covariance(np.arange(lags.size + 2, dtype=float), dt)  # K(u) = −½ S(u): R(j) = ΔS(j)/2 − ΔS(j−1)/2
        var = -2.0 * s
        r[0] += var[1]
        r[1:] += 0.5 * (var[2: lags.size + 1] - 2.0 * var[1: lags.size] + var[: lags.size - 1])
    w = np.concatenate([np.full(m, -1.0 / m), np.full(m, 1.0 / m)])
    count = n - 2 * m + 1
    offsets = np.arange(-(2 * m - 1), 2 * m)
    kernel = np.correlate(w, w, mode="full")  # Σ_a w_a w_{a+o} for o = −(2m−1) … 2m−1
    c = np.array([np.sum(kernel * r[np.abs(ell + offsets)]) for ell in range(count)])
    weight = (count - np.arange(count)).astype(float)
    weight[1:] *= 2.0
    var_av = float(np.sum(weight * 2.0 * c**2)) / (4.0 * count * count)
    return 2.0 * (0.5 * c[0]) ** 2 / var_av


@pytest.mark.parametrize("name", ["flicker, lines, averaging", "slow line and slow GM", "low-pass and walk"])
def test_the_edf_in_closed_form_equals_the_sum_over_every_lag(name):
    # Past 2m + its reach only exponential terms correlate the differences, summed as geometric series: the EDF must
    # be the one summed over every lag from the autocovariance.
    from imu_noise_id.core.noise.averaging import MA
    from imu_noise_id.core.noise.components import GM
    from imu_noise_id.core.noise.flicker import BI
    from imu_noise_id.core.noise.resonant import LPF, OSC

    n, dt = 4000, 0.01
    components = {
        "flicker, lines, averaging": [WN(7e-4), MA(5e-4), BI(1e-4, tau_min=0.02, tau_max=40.0),
                                      OSC(0.5, 0.01, 1e-3), OSC(7.0, 0.14, 1e-3)],
        "slow line and slow GM": [WN(1e-3), OSC(0.05, 0.02, 1e-3), GM(tau=500.0, sigma=1e-3)],
        "low-pass and walk": [WN(1e-3), LPF(2e-3, 5.0), RW(1e-4)],
    }[name]
    for m in (1, 3, 10, 40, 200):
        expected = _brute_force_edf(components, m, n, dt)
        assert model_av_edf(components, np.array([m]), n, dt)[0] == pytest.approx(expected, rel=1e-7)
