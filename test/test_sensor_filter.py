"""The sensor's own low-pass filter at high output rates: its noise is N, wherever its memory falls in samples.

A consumer part's lowest DLPF settings (5–10 Hz) at its 400 Hz–1 kHz output rates have a memory of 6–32 samples.
Read as a Gauss–Markov bias process, their noise was left out of N, which then held only the white floor behind the
filter: on a simulated 10 Hz DLPF at 400 Hz, `analyze` pasted a gyroscope noise density 10× below the truth.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from imu_noise_id.core.allan import allan_variance
from imu_noise_id.core.allan.slopes import fit_axis_slopes
from imu_noise_id.core.axes import ImuSeries
from imu_noise_id.core.estimation.em.relabel import gm_as_filter
from imu_noise_id.core.estimation.em.results import FitResult
from imu_noise_id.core.estimation.readouts import kalibr
from imu_noise_id.core.noise.components import GM, LPF, QN, RW, WN, simulate_sum
from imu_noise_id.core.noise.digital import DLPF as DLPF_TYPE
from imu_noise_id.core.noise.resonant import filter_memory_limit
from imu_noise_id.pipelines.analyze.final import final_model
from imu_noise_id.pipelines.analyze.models import ModelStage, fit_axis
from imu_noise_id.pipelines.loop import ImuLoop

RATE = 400.0
DT = 1.0 / RATE
#: A 10 Hz first-order DLPF on the gyro's noise (a memory of 16 ms: 6.4 samples at 400 Hz) behind a white floor
#: a tenth of its density.
DLPF = LPF(noise_density=1.5e-4, cutoff=10.0)
FLOOR = WN(1.5e-5)


def _fit_of(components: list, dt: float) -> FitResult:
    return FitResult(model="+".join(c.name for c in components), components=components, exog_coef={}, se={},
                     ci95={}, loglik=0.0, aic=0.0, bic=0.0, n=100_000, dt=dt, n_iter=0, converged=True)


def test_the_filter_memory_limit_is_five_samples_or_50_ms():
    assert filter_memory_limit(0.01) == pytest.approx(0.05)
    assert filter_memory_limit(DT) == pytest.approx(0.05)
    assert filter_memory_limit(1e-3) == pytest.approx(0.05)
    assert filter_memory_limit(1.0) == pytest.approx(5.0)


def test_a_gm_of_a_few_milliseconds_but_many_samples_is_the_filter_and_its_noise_is_n():
    """The GM a WN+GM+RW fit makes of the DLPF is renamed LPF, and N is the data's level below the corner (Welch PSD,
    0.5–2 Hz, of a simulation); a bias GM of τ = 2 s stays a GM, out of N."""
    fit = gm_as_filter(_fit_of([FLOOR, GM(DLPF.tau, DLPF.sigma), RW(2e-5)], DT))
    assert fit.model == "WN+LPF+RW"
    y = simulate_sum([FLOOR, DLPF], 400_000, DT, np.random.default_rng(2))
    f, pxx = signal.welch(y, fs=RATE, nperseg=4096)
    band = (f >= 0.5) & (f <= 2.0)
    level = math.sqrt(float(np.mean(pxx[band])) / 2.0)
    assert kalibr.noise_density(fit).value == pytest.approx(level, rel=0.03)
    bias = gm_as_filter(_fit_of([FLOOR, GM(2.0, 1e-3), RW(2e-5)], DT))
    assert bias.model == "WN+GM+RW" and kalibr.noise_density(bias).value == pytest.approx(FLOOR.noise_density)


def test_an_lpf_fitted_to_a_bias_processs_memory_stays_out_of_n():
    """At 1 Hz the loop offers an LPF for a short memory, and its fit may move the cutoff to a bias process's
    (τ = 60 s): such an LPF is a GM by another name, out of N and out of the per-sample noise."""
    slow = LPF.from_gm(60.0, 2e-3)
    fit = _fit_of([WN(2e-3), slow, RW(3e-4)], 1.0)
    assert kalibr.is_slow_lpf(slow, 1.0) and not kalibr.enters_n(slow, 1.0)
    assert kalibr.noise_density(fit).value == pytest.approx(2e-3)
    assert kalibr.per_sample_noise_variance(fit) == pytest.approx(4e-6)
    assert kalibr.enters_n(DLPF, DT) and not kalibr.is_slow_lpf(DLPF, DT)


@pytest.fixture(scope="module")
def dlpf_record() -> ImuSeries:
    """Three minutes at 400 Hz, every axis the DLPF-filtered noise with its floor and a random walk."""
    rng = np.random.default_rng(7)
    n = int(180 * RATE)
    data = np.column_stack([simulate_sum([FLOOR, DLPF, RW(2e-5)], n, DT, rng) for _ in range(6)])
    return ImuSeries(np.arange(n) * DT, data[:, :3], data[:, 3:])


def test_analyze_pastes_the_passband_density_of_a_10_hz_dlpf_at_400_hz(dlpf_record):
    """Model stage, closed loop and final model of one axis as ``analyze`` runs them: N within 5 % of the truth
    (the filtered noise and its floor as sampled) with an interval that holds it; before, N was the floor alone."""
    truth = kalibr.passband_density([FLOOR, DLPF], DT)
    allan = allan_variance(dlpf_record.gyro[:, 0], DT)
    model = fit_axis(dlpf_record, "gyro_x", ModelStage(), DT, allan)
    loop = ImuLoop(dlpf_record, None, intervals=True).run("gyro_x", model.fit)
    final = final_model(model.fit, loop, allan)
    n = final.noise_density
    assert n.value == pytest.approx(truth, rel=0.05)
    assert n.ci95[0] <= truth <= n.ci95[1]


def test_the_allan_slope_reading_leaves_the_low_pass_roll_off_out():
    """The AV of the DLPF record is flat at the shortest τ and falls as τ⁻¹ only beyond a few memories. Its Allan-
    slope N (the −½ line at τ = 1 s) is within 5 % of the truth and read from a fit, not a "bound" below it, and the
    roll-off is not taken for a bias-instability plateau; before, N was 7× low and labelled an upper bound."""
    y = simulate_sum([FLOOR, DLPF, RW(2e-5)], int(600 * RATE), DT, np.random.default_rng(3))
    s = fit_axis_slopes(allan_variance(y, DT))
    truth = kalibr.passband_density([FLOOR, DLPF], DT)
    assert s.noise_density.method == "fit" and s.noise_density.value == pytest.approx(truth, rel=0.05)
    assert s.bias_instability is None
    assert 5 * DLPF.tau < s.rolloff_tau < 25 * DLPF.tau


def test_a_second_order_dlpf_on_a_short_record_is_read_beyond_its_roll_off():
    """5 min at 200 Hz of white noise (1e-3) through a digital 2nd-order Butterworth at 12 Hz: the AV rises over the
    shortest τ (its global minimum is at τ = dt) and its single estimates wander around the −1 slope beyond the
    roll-off. Before, the roll-off went unseen and N was an "upper bound" of 8·10⁻⁵ read at τ = dt, 12× below the
    truth; now it is a fit within 5 % of it."""
    rate, n = 200.0, 60_000
    white = np.random.default_rng(7).standard_normal(n + 2000) * 1e-3 * math.sqrt(rate)
    y = signal.sosfilt(signal.butter(2, 12.0, fs=rate, output="sos"), white)[2000:]
    s = fit_axis_slopes(allan_variance(y, 1.0 / rate))
    assert s.rolloff_tau is not None
    assert s.noise_density.method == "fit" and s.noise_density.value == pytest.approx(1e-3, rel=0.05)
    assert s.noise_density.ci[0] <= 1e-3 <= s.noise_density.ci[1]


@pytest.mark.parametrize("components", [[WN(1e-3), QN(3e-4)], [WN(1e-3), RW(1e-4)], [WN(1e-3), GM(2.0, 3e-3)]],
                         ids=["quantisation", "random walk", "bias GM"])
def test_a_curve_without_a_low_pass_is_read_whole(components):
    y = simulate_sum(components, 200_000, 0.01, np.random.default_rng(1))
    assert fit_axis_slopes(allan_variance(y, 0.01)).rolloff_tau is None


@pytest.mark.parametrize("order", [1, 2, 4])
def test_a_sensor_filter_is_judged_by_its_cutoff_whatever_its_order(order):
    """A Butterworth low-pass at 5 Hz is the sensor's filter at any order: its memory 1/(2π f_c) = 32 ms is below the
    50 ms limit. A 4th-order one's slowest pole decays over 83 ms, and judged by that the fit's DLPF (cutoff and order
    right) was left out of N: N was the 10× smaller floor behind it, and the axis ended unresolved."""
    dt = 1.0 / 200.0
    lowpass = DLPF_TYPE(noise_density=1e-3, cutoff=5.0, order=order)
    assert kalibr.enters_n(lowpass, dt) and not kalibr.is_slow_lpf(lowpass, dt)
    assert kalibr.passband_density([WN(1e-4), lowpass], dt) == pytest.approx(math.hypot(1e-3, 1e-4), rel=0.02)
    slow = DLPF_TYPE(noise_density=1e-3, cutoff=2.0, order=order)  # 80 ms: a bias process's memory, out of N
    assert kalibr.is_slow_lpf(slow, dt) and not kalibr.enters_n(slow, dt)
