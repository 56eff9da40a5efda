"""The sensor's averaging filter (MA): exact moments of the two-tap moving average, its fit, and the closed loop
telling it from a first-order low-pass (LPF) — each against a simulated truth."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imu_noise_id.core.estimation.em.model import NoiseModel
from imu_noise_id.core.estimation.readouts import kalibr
from imu_noise_id.core.noise.components import LPF, MA, RW, WN, simulate_sum
from imu_noise_id.core.noise.modelspec import parse_model
from imu_noise_id.pipelines.loop import run_closed_loop

DT = 0.01


def test_autocovariance_psd_and_allan_variance_of_a_two_tap_average():
    """R(0) = 2σ², R(dt) = σ², R(2dt) = 0 with σ² = N²/(4 dt); PSD N² cos²(πf dt) (N² at f → 0);
    AV = (4m − 3)σ²/m² exactly, from the sample AV of a long simulation."""
    ma = MA(2e-3)
    s2 = ma.sigma2(DT)
    assert s2 == pytest.approx(2e-3**2 / (4 * DT))
    y = ma.simulate(2_000_000, DT, np.random.default_rng(1))
    r = [float(np.mean(y[: y.size - k] * y[k:])) for k in range(3)]
    assert r[0] == pytest.approx(2 * s2, rel=0.01) and r[1] == pytest.approx(s2, rel=0.02)
    assert abs(r[2]) < 0.01 * s2
    assert float(ma.psd(1e-6, DT)) == pytest.approx(2e-3**2) and float(ma.psd(0.5 / DT * 0.999, DT)) < 1e-8
    for m in (1, 2, 5, 50):
        c = np.concatenate([[0.0], np.cumsum(y)])
        d = c[2 * m:] - 2 * c[m:-m] + c[: -2 * m]
        assert float(np.mean(d**2) / (2 * m * m)) == pytest.approx(float(ma.allan_variance(m * DT, DT)), rel=0.02)
    assert float(ma.allan_variance(1e4 * DT, DT)) == pytest.approx(2e-3**2 / (1e4 * DT), rel=1e-3)


def test_per_sample_round_trip_and_passband_numbers():
    ma = MA(2e-3)
    assert MA.from_per_sample(DT, **ma.per_sample(DT)).noise_density == pytest.approx(2e-3, rel=1e-12)
    blk = ma.block(DT)
    assert MA.from_block(blk.phi, blk.q, DT).noise_density == pytest.approx(2e-3, rel=1e-12)
    assert parse_model("WN(1e-3)+MA(2e-3)+RW(1e-5)")[1] == ma


def test_fit_recovers_the_white_and_averaged_parts_and_kalibr_sums_them():
    """WN + MA + RW fitted by the EM and the quasi-Newton finish: both densities within a few per cent; Kalibr's N is
    the passband √(N_WN² + N_MA²) and the per-sample variance N_WN²/dt + N_MA²/(2 dt), below N²/dt."""
    y = simulate_sum([WN(1e-3), MA(2e-3), RW(1e-5)], 200_000, DT, np.random.default_rng(3))
    fit = NoiseModel(y, DT, "WN+MA+RW").fit()
    wn, ma, _ = fit.components
    assert wn.noise_density == pytest.approx(1e-3, rel=0.1) and ma.noise_density == pytest.approx(2e-3, rel=0.05)
    n = kalibr.noise_density(fit)
    assert n.value == pytest.approx(math.hypot(1e-3, 2e-3), rel=0.02) and n.ci95[0] < n.value < n.ci95[1]
    per_sample = kalibr.per_sample_noise_variance(fit)
    assert per_sample == pytest.approx(wn.noise_density**2 / DT + ma.noise_density**2 / (2 * DT))
    assert per_sample < n.value**2 / DT


@pytest.mark.parametrize(("truth", "expected"), [(MA(2e-3), "MA"), (LPF(2e-3, 15.0), "LPF")], ids=["MA", "LPF"])
def test_loop_tells_the_averaging_filter_from_a_low_pass(truth, expected):
    """Both are offered on the same short-memory evidence; the likelihood keeps the one that made the data (the
    first step, and re-selection after it, is the claim: the steps after it took 40 % of the time)."""
    y = simulate_sum([WN(5e-4), truth, RW(1e-5)], 120_000, DT, np.random.default_rng(5))
    result = run_closed_loop(y, DT, "WN+RW", axis="gyro_x", max_steps=1)
    assert result.steps[1].added == expected, [(t.model, t.accepted, t.reason) for t in result.steps[0].trials]
    filters = {c.name for c in result.final.diagnosis.fit.components} & {"LPF", "MA"}
    assert filters == {expected}
