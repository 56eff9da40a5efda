"""Components: unit conversions are exact inverses, simulations match their theoretical moments."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imu_noise_id.core.noise import units
from imu_noise_id.core.noise.components import GM, QN, RR, RW, WN, simulate_sum, total_allan_variance
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
    [WN(2e-3), QN(1e-5), RW(3e-5), GM(tau=50.0, sigma=1e-3), RR(1e-6)],
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
    assert gm.allan_variance(0.01, DT) == pytest.approx(q_c * 0.01 / 3, rel=1e-3)
    assert gm.allan_variance(1e6, DT) == pytest.approx(2 * gm.sigma**2 * gm.tau / 1e6, rel=1e-3)
    # continuity across the series/closed-form switch at tau/tau_c = 1e-3
    a, b = gm.allan_variance(np.array([0.0999999, 0.1000001]), DT)
    assert a == pytest.approx(b, rel=1e-5)


def test_psd_to_allan_variance_relation():
    """AV(τ) = 4∫ S(f) sin⁴(πfτ)/(πfτ)² df for the continuous-time components (paper 000 section 2)."""
    tau, f_max, df = 2.0, 2000.0, 1e-3
    f = np.arange(1, int(f_max / df) + 1) * df
    for comp in (WN(1e-3), GM(tau=3.0, sigma=1e-3)):
        integrand = comp.psd(f, DT) * np.sin(np.pi * f * tau) ** 4 / (np.pi * f * tau) ** 2
        val = 4 * np.trapezoid(integrand, f)
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
