"""Components: unit conversions are exact inverses, simulations match their theoretical moments."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imu_noise_id.core.noise import units
from imu_noise_id.core.noise.components import BI, GM, LPF, MA, OSC, QN, RR, RW, WN, simulate_sum, total_allan_variance
from imu_noise_id.core.noise.modelspec import (
    ModelSpecError,
    model_name,
    parse_imu_model,
    parse_model,
    parse_structure,
)

DT = 0.01


@pytest.mark.parametrize(
    "component",
    [WN(2e-3), QN(1e-5), RW(3e-5), GM(tau=50.0, sigma=1e-3), RR(1e-6), LPF(1e-3, 15.0), OSC(0.5, 0.05, 6e-3)],
    ids=lambda c: c.name,
)
def test_per_sample_round_trip(component):
    back = type(component).from_per_sample(DT, **component.per_sample(DT))
    for key, value in component.params().items():
        assert back.params()[key] == pytest.approx(value, rel=1e-12)


def test_kalibr_discrete_conventions():
    # Kalibr: sigma_d = N / sqrt(dt), sigma_bd = K * sqrt(dt).
    assert math.sqrt(units.white_noise_sigma2(1.6e-4, 0.005)) == pytest.approx(1.6e-4 / math.sqrt(0.005))
    assert math.sqrt(units.random_walk_sigma2(2e-5, 0.005)) == pytest.approx(2e-5 * math.sqrt(0.005))
    assert units.covariance_from_density(1e-3, 200.0) == pytest.approx(2e-4)


def test_the_random_walk_read_off_an_allan_variance_has_that_allan_variance():
    # K = sqrt(3 AV / tau) inverts the random walk's continuous AV K^2 tau / 3 (its sampled AV adds K^2 dt^2/(6 tau))
    tau = np.array([1.0, 10.0, 400.0])
    k = units.random_walk_at_allan_variance(RW(3e-4).allan_variance(tau, 1e-6), tau)
    assert k == pytest.approx(np.full(3, 3e-4), rel=1e-9)
    assert isinstance(units.random_walk_at_allan_variance(3e-8, 1.0), float)
    assert units.random_walk_at_allan_variance(3e-8, 1.0) == pytest.approx(3e-4)


def test_gm_paper_notation():
    gm = GM(tau=125.0, sigma=0.5)
    p = gm.per_sample(1.0)
    assert p["beta"] == pytest.approx(0.008)
    assert p["sigma2_gm"] == pytest.approx(0.25)
    assert p["phi"] == pytest.approx(math.exp(-0.008))
    assert p["sigma2_drive"] == pytest.approx(0.25 * (1 - math.exp(-0.016)))


@pytest.mark.parametrize("bad", [dict(noise_density=-1.0), dict(noise_density=float("nan"))])
def test_bad_parameters_rejected(bad):
    with pytest.raises(ValueError, match="noise_density"):
        WN(**bad)


def test_gm_zero_tau_rejected():
    with pytest.raises(ValueError, match="tau"):
        GM(tau=0.0, sigma=1.0)


def _sample_av(x: np.ndarray, m: int) -> float:
    c = np.concatenate([[0.0], np.cumsum(x)])
    d = c[2 * m :] - 2 * c[m:-m] + c[: -2 * m]
    return float(np.mean(d**2) / (2 * m * m))


@pytest.mark.parametrize(
    "component",
    [WN(2e-3), QN(1e-5), RW(3e-4), GM(tau=0.5, sigma=1e-3), RR(1e-3)],
    ids=lambda c: c.name,
)
def test_simulated_allan_variance_matches_theory(component):
    """Average of the sample AV over 40 seeds lies within 4 standard errors of the theory."""
    n, m = 20000, 10
    rng = np.random.default_rng(1)
    avs = np.array([_sample_av(component.simulate(n, DT, rng), m) for _ in range(40)])
    theory = float(component.allan_variance(m * DT, DT))
    if isinstance(component, RR):
        assert avs.mean() == pytest.approx(theory, rel=1e-9)
        return
    assert abs(avs.mean() - theory) < 4 * avs.std(ddof=1) / math.sqrt(len(avs))


def test_gm_allan_variance_limits():
    gm = GM(tau=100.0, sigma=2e-3)
    q_c = 2 * gm.sigma**2 / gm.tau
    # tau << tau_c: random-walk-like K² tau / 3 with K² = 2σ²/τ_c; tau >> tau_c: white with N² = 2σ²τ_c.
    # (sampled: at τ = dt the sampled random walk's K²(τ/3 + dt²/(6τ)) = K² dt / 2)
    assert gm.allan_variance(0.01, DT) == pytest.approx(RW(math.sqrt(q_c)).allan_variance(0.01, DT), rel=1e-3)
    assert gm.allan_variance(1e6, DT) == pytest.approx(2 * gm.sigma**2 * gm.tau / 1e6, rel=1e-3)
    # continuity across the series/closed-form switch at tau/tau_c = 1e-3
    a, b = gm.allan_variance(np.array([0.0999999, 0.1000001]), DT)
    assert a == pytest.approx(b, rel=1e-5)


def test_psd_to_allan_variance_relation():
    """AV(τ) = 4∫ S(f) sin⁴(πfτ)/(πfτ)² df for the continuous-time components (paper 000 section 2)."""
    from scipy import integrate  # numpy's trapezoid is numpy ≥ 2; requirements.txt allows 1.24

    tau, f_max, df = 2.0, 2000.0, 1e-3
    f = np.arange(1, int(f_max / df) + 1) * df
    for comp in (WN(1e-3), GM(tau=3.0, sigma=1e-3)):
        integrand = comp.psd(f, DT) * np.sin(np.pi * f * tau) ** 4 / (np.pi * f * tau) ** 2
        val = 4 * integrate.trapezoid(integrand, f)
        # beyond f_max sin⁴ averages 3/8 and the PSD is at most flat: add that tail analytically
        val += 4 * 3 / 8 * float(comp.psd(f_max, DT)) / (np.pi * tau) ** 2 / f_max
        assert val == pytest.approx(float(comp.allan_variance(tau, DT)), rel=1e-3)


def test_sum_simulation_is_reproducible_and_av_adds():
    comps = [WN(1e-3), RW(1e-5)]
    a = simulate_sum(comps, 1000, DT, np.random.default_rng(3))
    b = simulate_sum(comps, 1000, DT, np.random.default_rng(3))
    np.testing.assert_array_equal(a, b)
    tau = np.array([0.1, 1.0])
    expected = comps[0].allan_variance(tau, DT) + comps[1].allan_variance(tau, DT)
    np.testing.assert_allclose(total_allan_variance(comps, tau, DT), expected)


def test_model_spec_parsing():
    assert parse_structure("WN+2GM+RW") == ["WN", "GM", "GM", "RW"]
    comps = parse_model("WN(2e-4) + GM(tau=300, sigma=5e-5) + RW(random_walk=3e-6)")
    assert comps == [WN(2e-4), GM(300.0, 5e-5), RW(3e-6)]
    assert model_name([RW(1.0), GM(1.0, 1.0), WN(1.0), GM(2.0, 1.0)]) == "WN+2GM+RW"
    imu = parse_imu_model("gyro: WN(1e-3)+RW(1e-5); accel: WN(2e-2); accel_z: WN(3e-2)")
    assert imu["gyro_y"] == [WN(1e-3), RW(1e-5)]
    assert imu["accel_x"] == [WN(2e-2)]
    assert imu["accel_z"] == [WN(3e-2)]


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("", "empty"),
        ("WN+", "empty term"),
        ("XX(1)", "unknown component"),
        ("WN", "needs parameter values"),
        ("GM(tau=1)", "needs sigma"),
        ("WN(foo=1)", "no parameter"),
        ("WN(abc)", "not a number"),
        ("WN(-1)", "noise_density"),
    ],
)
def test_model_spec_errors(spec, message):
    with pytest.raises(ModelSpecError, match=message):
        parse_model(spec)


# -- the sensor's low-pass filter (LPF) and the narrow-band oscillation (OSC) ---------------------------------

def _av_from_psd(component, tau: float) -> float:
    """AV(τ) = 4∫₀^∞ S(f) sin⁴(πfτ)/(πfτ)² df by quadrature of the component's two-sided PSD."""
    from scipy import integrate

    f = np.concatenate([np.linspace(1e-6, 5.0, 1_000_001), np.geomspace(5.0, 1e4, 100_001)[1:]])
    x = math.pi * f * tau
    return 4.0 * float(integrate.trapezoid(component.psd(f, DT) * np.sin(x) ** 4 / x**2, f))


@pytest.mark.parametrize("component", [OSC(0.5, 0.05, 6e-3), OSC(3.0, 0.6, 1e-3), LPF(1e-3, 20.0)],
                         ids=str)
@pytest.mark.parametrize("tau", [0.01, 0.3, 3.0, 30.0])
def test_sampled_allan_variance_tends_to_the_continuous_psd_integral(component, tau):
    """With samples much closer than the process's memory the sampled AV is the continuous-time one."""
    memory = 1.0 / (2.0 * math.pi * (component.cutoff if isinstance(component, LPF) else component.frequency))
    fine = min(tau, memory) / 200.0
    assert component.allan_variance(np.array([tau]), fine)[0] == pytest.approx(_av_from_psd(component, tau),
                                                                               rel=2e-4)


def _autocovariance(component, lag_s: np.ndarray) -> np.ndarray:
    """R(u) of the component written out independently of the code under test (module docstrings)."""
    if isinstance(component, LPF):
        tau_c = 1.0 / (2.0 * math.pi * component.cutoff)
        return math.pi * component.noise_density**2 * component.cutoff * np.exp(-lag_s / tau_c)
    if isinstance(component, GM):
        return component.sigma**2 * np.exp(-lag_s / component.tau)
    if isinstance(component, BI):  # the flicker ladder: a sum of GMs of equal variance
        return sum(component.sigma2_each * np.exp(-lag_s / t) for t in component.taus)
    zeta = component.bandwidth / (2.0 * component.frequency)
    w0 = 2.0 * math.pi * component.frequency
    a, wd = zeta * w0, w0 * math.sqrt(1.0 - zeta**2)
    return component.sigma**2 * np.exp(-a * lag_s) * (np.cos(wd * lag_s) + a / wd * np.sin(wd * lag_s))


@pytest.mark.parametrize("component", [OSC(0.5, 0.05, 6e-3), OSC(3.0, 0.6, 1e-3), LPF(1e-3, 20.0), GM(0.02, 1e-3),
                                       GM(300.0, 2e-5), BI(3e-4, 0.05, 500.0)], ids=str)
@pytest.mark.parametrize("m", [1, 2, 7, 100, 1000])
def test_sampled_allan_variance_equals_the_sum_over_the_autocovariance(component, m):
    """AV(m·dt) of the samples = (4S(m) − S(2m))/(2m²), S(k) = Σ_{|j|<k} (k − |j|) R(j·dt), summed directly."""
    def block_sum_variance(k: int) -> float:
        j = np.arange(1, k)
        return k * float(_autocovariance(component, np.zeros(1))[0]) + 2.0 * float(
            np.sum((k - j) * _autocovariance(component, j * DT)))

    expected = (4.0 * block_sum_variance(m) - block_sum_variance(2 * m)) / (2.0 * m * m)
    assert component.allan_variance(np.array([m * DT]), DT)[0] == pytest.approx(expected, rel=1e-6)


def test_osc_block_is_the_exact_discretisation_of_a_stationary_oscillator():
    """Φ P∞ Φᵀ + Q = P∞ (stationary), Φ's poles are e^{(−ζω₀ ± iω_d)dt}, and from_block inverts block."""
    osc = OSC(0.5, 0.05, 6e-3)
    blk = osc.block(DT)
    p = osc.stationary_covariance()
    np.testing.assert_allclose(blk.phi @ p @ blk.phi.T + blk.q, p, rtol=1e-10, atol=1e-18)
    lam = np.linalg.eigvals(blk.phi)
    z, w0 = osc.damping, 2 * math.pi * 0.5
    assert abs(lam[0]) == pytest.approx(math.exp(-z * w0 * DT), rel=1e-12)
    assert abs(np.angle(lam[0])) == pytest.approx(w0 * math.sqrt(1 - z * z) * DT, rel=1e-12)
    back = OSC.from_block(blk.phi, blk.q, DT)
    for key, value in osc.params().items():
        assert back.params()[key] == pytest.approx(value, rel=1e-9)


@pytest.mark.parametrize("osc", [OSC(0.5, 0.05, 6e-3), OSC(3.0, 0.6, 1e-3), OSC(1e-3, 5e-4, 1.0),
                                 OSC(0.4, 2e-5, 2.0), OSC(45.0, 30.0, 1e-2), OSC(49.0, 1e-3, 1.0)], ids=str)
def test_osc_process_noise_is_the_van_loan_integral(osc: OSC):
    """The closed-form Q equals ∫₀^dt e^{Aτ} B q Bᵀ e^{Aᵀτ} dτ by Van Loan's matrix exponential (an independent
    computation), from slow and narrow lines to wide ones near the Nyquist frequency."""
    from scipy.linalg import expm

    w0, a = osc.omega0, osc.damping * osc.omega0
    generator = np.array([[0.0, w0], [-w0, -2.0 * a]])
    m = np.zeros((4, 4))
    m[:2, :2], m[:2, 2:], m[2:, 2:] = -generator, np.diag([0.0, 4.0 * a * osc.sigma**2]), generator.T
    e = expm(m * DT)
    van_loan = e[2:, 2:].T @ e[:2, 2:]
    q = osc.process_noise(DT)
    np.testing.assert_allclose(q, 0.5 * (van_loan + van_loan.T), rtol=0, atol=1e-12 * np.abs(van_loan).max())
    np.testing.assert_allclose(osc.block(DT).phi, e[2:, 2:].T, rtol=0, atol=1e-13)


def test_osc_simulation_has_its_variance_and_its_line():
    osc = OSC(2.0, 0.2, 1e-2)
    y = np.concatenate([osc.simulate(100_000, DT, np.random.default_rng(s)) for s in range(8)])
    assert y.var() == pytest.approx(1e-4, rel=0.05)  # ≈ 1000 correlation times of 1/(ζω₀) = 0.8 s per run
    f = np.fft.rfftfreq(100_000, DT)
    power = np.abs(np.fft.rfft(y[:100_000])) ** 2
    assert f[np.argmax(power)] == pytest.approx(2.0, abs=0.2)


def test_lpf_is_a_gauss_markov_process_with_its_passband_density():
    """LPF(N, f_c) = GM(τ = 1/2πf_c, σ² = πN²f_c): PSD N² at f ≪ f_c, half of it at f_c; per-sample σ² < N²/dt."""
    lpf = LPF(1e-3, 20.0)
    gm = GM(tau=1 / (2 * math.pi * 20.0), sigma=1e-3 * math.sqrt(math.pi * 20.0))
    f = np.array([0.01, 1.0, 20.0, 200.0])
    np.testing.assert_allclose(lpf.psd(f, DT), gm.psd(f, DT), rtol=1e-12)
    assert lpf.psd(np.array([0.01]), DT)[0] == pytest.approx(1e-6, rel=1e-6)
    assert lpf.psd(np.array([20.0]), DT)[0] == pytest.approx(0.5e-6, rel=1e-12)
    assert lpf.sigma**2 < 1e-6 / DT


def test_osc_low_pass_is_the_butterworth_filter_of_white_noise_of_its_passband_density():
    """OSC.low_pass(N, f₀): PSD N² at f ≪ f₀, half of it at f₀ (ζ = 1/√2: |H(f₀)|² = 1/4ζ²), then −40 dB a
    decade where the first-order LPF falls by −20; the samples' zero-frequency level is N when its memory spans
    many samples; another damping keeps S(0) = N² with |H(f₀)|² = 1/4ζ²."""
    second, first = OSC.low_pass(1e-3, 2.0), LPF(1e-3, 2.0)
    assert second.frequency == 2.0 and second.damping == pytest.approx(1 / math.sqrt(2), rel=1e-12)
    f = np.array([1e-3, 2.0, 200.0])
    np.testing.assert_allclose(second.psd(f, DT), [1e-6, 0.5e-6, 1e-6 * 1e-8], rtol=1e-3)
    assert first.psd(f, DT)[2] == pytest.approx(1e-6 * 1e-4, rel=1e-3)
    assert second.zero_frequency_density(DT) == pytest.approx(1e-3, rel=1e-6)
    damped = OSC.low_pass(1e-3, 2.0, damping=0.9)
    np.testing.assert_allclose(damped.psd(f[:2], DT), [1e-6, 1e-6 / (4 * 0.81)], rtol=1e-6)


def test_osc_refuses_what_is_not_a_resonance():
    with pytest.raises(ValueError, match="too wide"):
        OSC(1.0, 3.0, 1e-3)
    with pytest.raises(ValueError, match="Nyquist"):
        OSC(60.0, 1.0, 1e-3).block(DT)


SUM_COV_COMPONENTS = [WN(1e-3), QN(2e-5), RW(4e-4), GM(0.05, 1e-3), GM(30.0, 2e-4), LPF(1e-3, 20.0), MA(1e-3),
                      BI(2e-4, 0.1, 100.0),
                      OSC(3.0, 0.6, 1e-3)]


@pytest.mark.parametrize("component", SUM_COV_COMPONENTS, ids=str)
def test_sum_covariance_gives_the_allan_variance(component):
    """AV(m·dt) = (6K(0) − 8K(m) + 2K(2m)) / (2m²) for the generalised covariance K of the partial sums (RR has no
    randomness: K = 0, its AV is that of its mean)."""
    assert not np.any(RR(1e-3).sum_covariance(np.arange(5), DT))
    m = np.array([1, 2, 3, 8, 64, 1000])
    k = lambda u: component.sum_covariance(np.asarray(u), DT)  # noqa: E731
    from_k = (6.0 * k(0) - 8.0 * k(m) + 2.0 * k(2 * m)) / (2.0 * m * m)
    np.testing.assert_allclose(from_k, component.allan_variance(m * DT, DT), rtol=1e-9, atol=0.0)


@pytest.mark.parametrize("component", [c for c in SUM_COV_COMPONENTS if c.name in ("GM", "LPF", "OSC")], ids=str)
def test_sum_covariance_of_a_stationary_component_is_minus_half_the_block_sum_variance(component):
    for u in (1, 5, 40):
        j = np.arange(1, u)
        direct = u * float(_autocovariance(component, np.zeros(1))[0]) + 2.0 * float(
            np.sum((u - j) * _autocovariance(component, j * DT)))
        assert component.sum_covariance(np.array([u]), DT)[0] == pytest.approx(-0.5 * direct, rel=1e-9)


def test_sum_covariance_cross_filters_match_simulation():
    """Cov(Δ²₁x_t, Δ²₃x_{t+2}) = Σ c_a d_b K(q_b − p_a) for WN+QN+RW, against 2·10⁶ simulated samples."""
    comps = [WN(1e-3), QN(3e-5), RW(3e-3)]
    y = simulate_sum(comps, 2_000_000, DT, np.random.default_rng(4))
    x = np.concatenate([[0.0], np.cumsum(y)])
    a = x[2:] - 2 * x[1:-1] + x[:-2]  # Δ²₁ x_t at t = 0..N−2 (offsets 0, 1, 2)
    b = x[6:] - 2 * x[3:-3] + x[:-6]  # Δ²₃ x_t (offsets 0, 3, 6)
    lag = 2
    prod = a[:b.size - lag] * b[lag:]
    kk = lambda u: sum(c.sum_covariance(np.asarray(u), DT) for c in comps)  # noqa: E731
    theory = sum(ca * cb * kk(lag + pb - pa) for ca, pa in zip((1, -2, 1), (0, 1, 2), strict=True)
                 for cb, pb in zip((1, -2, 1), (0, 3, 6), strict=True))
    # Products of overlapping differences are correlated over a few lags: 3 × the iid standard error, 4 of them.
    assert float(np.mean(prod)) == pytest.approx(float(theory), abs=12.0 * float(np.std(prod)) / math.sqrt(prod.size))
    assert abs(float(theory)) > 20.0 * float(np.std(prod)) / math.sqrt(prod.size)  # the check can fail


@pytest.mark.parametrize("component", [WN(1e-3), MA(2e-3), LPF(1e-3, 45.0), LPF(1e-3, 0.5), OSC(31.5, 50.0, 2e-2),
                                       OSC(3.0, 0.6, 1e-3)], ids=str)
def test_zero_frequency_density_is_the_long_tau_allan_level_of_the_sampled_component(component):
    """τ·AV(τ) → N² beyond the memory (AV of the sampled process, exact): the density a filter integrating the samples
    sees; the continuous PSD at 0 Hz only when the memory is many samples long."""
    tau = np.array([1e5 * DT])
    level = float(component.allan_variance(tau, DT)[0] * tau[0])
    assert component.zero_frequency_density(DT) ** 2 == pytest.approx(level, rel=2e-3)
    if component.memory(DT)[0] > 10 * DT:  # LPF(0.5 Hz), OSC(3 Hz)
        assert component.zero_frequency_density(DT) ** 2 == pytest.approx(float(component.psd(1e-9, DT)), rel=1e-2)
