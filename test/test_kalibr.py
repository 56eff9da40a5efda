"""Kalibr's N and the per-sample variance from models that hold short-memory oscillations (issue 11: nothing
that is white noise at low frequency may be left out of N, no vibration line may be put into it)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from imu_noise_id.core.estimation.em.model import FitOptions, NoiseModel
from imu_noise_id.core.estimation.em.results import FitResult
from imu_noise_id.core.estimation.readouts import kalibr
from imu_noise_id.core.noise.components import LPF, OSC, RW, WN, simulate_sum, total_allan_variance

DT = 0.01
WHITE = WN(3.5e-3)
#: A broad OSC as the loop fits a MEMS accelerometer's internal filter (ADIS16405 run 6 accel_y: 31.7 Hz, 50 Hz).
BROAD = OSC(31.5, 50.0, 0.02)
#: A vibration line (the ADIS16405's ≈ 10.8 Hz one): a memory of 0.6 s.
LINE = OSC(10.8, 0.5, 0.005)


def _fit_of(components, ci95=None) -> FitResult:
    return FitResult(model="+".join(c.name for c in components), components=components, exog_coef={}, se={},
                     ci95=ci95 or {}, loglik=0.0, aic=0.0, bic=0.0, n=100_000, dt=DT, n_iter=0, converged=True)


def test_n_is_the_low_frequency_density_of_white_noise_and_a_broad_osc_and_leaves_a_line_out():
    """N² equals the two-sided PSD below the broad OSC's corner and away from the line, measured on a simulation
    (Welch, 0.5–5 Hz); a WN-only N would be 19 % low. The per-sample variance is that of the simulated high-frequency
    noise (white plus broad OSC)."""
    fit = _fit_of([WHITE, BROAD, LINE])
    n = kalibr.noise_density(fit)
    rng = np.random.default_rng(4)
    y = simulate_sum([WHITE, BROAD, LINE], 400_000, DT, rng)
    f, pxx = signal.welch(y, fs=1 / DT, nperseg=1024)
    band = (f >= 0.5) & (f <= 5.0)
    measured = math.sqrt(float(np.mean(pxx[band])) / 2.0)  # one-sided Welch → the two-sided density
    assert n.value == pytest.approx(measured, rel=0.02)
    assert WHITE.noise_density < 0.85 * n.value
    assert "OSC1" in n.source and "OSC2" not in n.source
    high = simulate_sum([WHITE, BROAD], 400_000, DT, rng)
    assert kalibr.per_sample_noise_variance(fit) == pytest.approx(float(high.var()), rel=0.01)


def test_n_of_a_low_pass_near_nyquist_is_its_density_as_sampled():
    """An LPF at 45 Hz sampled at 100 Hz (the ADIS16405 accelerometers' fitted filter): the samples alias its tail,
    and the data's low-frequency level — Welch PSD and τ·AV at long τ — is 1.27 times its continuous density N_LPF.
    N is that level (the continuous N_LPF read 15 % low on the measured axes)."""
    lpf, white = LPF(2.7e-3, 45.0), WN(1e-3)
    n = kalibr.noise_density(_fit_of([white, lpf]))
    y = simulate_sum([white, lpf], 400_000, DT, np.random.default_rng(6))
    f, pxx = signal.welch(y, fs=1 / DT, nperseg=1024)
    band = (f >= 0.5) & (f <= 5.0)
    assert n.value == pytest.approx(math.sqrt(float(np.mean(pxx[band])) / 2.0), rel=0.02)
    tau = np.array([1e3])
    assert n.value**2 == pytest.approx(float(total_allan_variance([white, lpf], tau, DT)[0] * tau[0]), rel=1e-3)
    assert lpf.zero_frequency_density(DT) == pytest.approx(1.27 * lpf.noise_density, rel=0.01)


def test_ns_interval_without_covariance_takes_the_end_of_each_parameter_that_lowers_or_raises_n():
    """No log-covariance: the broad OSC's density takes σ's and B's lower ends and f₀'s upper end for N's lower
    limit, and the reverse for the upper one (each within 2 % of the density evaluated there: N_i is linearised in
    the log-parameters)."""
    ci = {"WN.noise_density": (3.3e-3, 3.7e-3), "OSC.frequency": (28.0, 36.0), "OSC.bandwidth": (40.0, 50.0),
          "OSC.sigma": (0.015, 0.025)}
    n = kalibr.noise_density(_fit_of([WHITE, BROAD], ci))
    lo = math.hypot(3.3e-3, OSC(36.0, 40.0, 0.015).zero_frequency_density(DT))
    hi = math.hypot(3.7e-3, OSC(28.0, 50.0, 0.025).zero_frequency_density(DT))
    assert n.ci95 == pytest.approx((lo, hi), rel=0.02)
    assert n.ci95[0] < n.value < n.ci95[1]


def test_a_fitted_white_noise_and_broad_osc_give_n_within_a_few_per_cent_with_an_interval_holding_it():
    """WN + broad OSC fitted by maximum likelihood (20 000 samples): the likelihood splits the passband between the
    two loosely, their N within 3 % of the truth √(N_WN² + N_OSC²), its delta-method interval around it."""
    truth = math.hypot(WHITE.noise_density, BROAD.zero_frequency_density(DT))
    y = simulate_sum([WHITE, BROAD], 20_000, DT, np.random.default_rng(4))
    fit = NoiseModel(y, DT, "WN+OSC").fit(init=[WN(3e-3), OSC(25.0, 40.0, 0.015)], options=FitOptions(n_starts=1))
    n = kalibr.noise_density(fit)
    assert n.value == pytest.approx(truth, rel=0.03)
    assert n.ci95[0] < truth < n.ci95[1]
    assert fit.components[0].noise_density < 0.9 * truth  # the white noise alone: the N this replaced


def test_a_walk_the_record_does_not_identify_is_given_as_its_upper_end():
    """K whose 95 % interval reaches zero is given as that interval's upper end, method ``bound``, interval (0, it):
    on 10 min at 200 Hz of WN (1e-3) + RW (1e-5) the fits gave K = 1e-7 and 1e-10 on two axes — 100× below the
    truth, not a bound."""
    from imu_noise_id.core.estimation.readouts.kalibr import KalibrValue, unidentified_as_bound

    low = unidentified_as_bound(KalibrValue(1.0e-10, (0.0, 1.5e-5), "RW"))
    assert (low.value, low.ci95, low.method) == (1.5e-5, (0.0, 1.5e-5), "bound") and "reaches zero" in low.source
    kept = KalibrValue(2e-5, (1.1e-5, 4.5e-5), "RW")
    assert unidentified_as_bound(kept) is kept
    none = KalibrValue(None, (math.nan, math.nan), "no RW")
    assert unidentified_as_bound(none) is none


def test_a_walk_whose_interval_has_no_upper_end_takes_the_datas_bound():
    """K fitted beside a line with the interval [0, inf) (an oscillation record of the random-walk bench) was pasted as
    a model value: neither end bounds it. It takes the data's long-tau bound, as a model without a walk does."""
    from imu_noise_id.core.allan.rw_bound import RandomWalkBound
    from imu_noise_id.core.estimation.readouts.kalibr import KalibrValue, unidentified_as_bound, unmodelled_as_bound

    bound = RandomWalkBound(3e-5, 0.95, (120.0, 300.0), 200.0)
    open_ended = unidentified_as_bound(KalibrValue(2.5e-5, (0.0, math.inf), "RW"))
    k = unmodelled_as_bound(open_ended, bound)
    assert (k.value, k.ci95, k.method) == (3e-5, (0.0, 3e-5), "bound") and "not identified" in k.source
    finite = KalibrValue(2.5e-5, (1e-5, 4e-5), "RW")
    assert unmodelled_as_bound(finite, bound) is finite


def _final_models(y: np.ndarray, dt: float, *structures: str) -> list:
    """The final model (no loop) of each of ``structures`` fitted to ``y`` as gyro_x, as ``analyze`` builds it."""
    from imu_noise_id.core.allan import allan_variance
    from imu_noise_id.core.axes import ImuSeries
    from imu_noise_id.pipelines.analyze.final import final_model
    from imu_noise_id.pipelines.analyze.models import ModelStage, fit_axis

    data = np.column_stack([y] * 6)
    imu = ImuSeries(np.arange(y.size) * dt, data[:, :3], data[:, 3:])
    allan = allan_variance(y, dt)
    return [final_model(fit_axis(imu, "gyro_x", ModelStage(s), dt, allan).fit, None, allan) for s in structures]


def test_a_short_record_gives_k_as_a_bound_at_or_above_the_truth_and_says_so():
    from imu_noise_id.core.noise.components import RW, WN, simulate_sum
    from imu_noise_id.report.console import final_table

    dt = 0.005
    y = simulate_sum([WN(1e-3), RW(1e-5)], 120_000, dt, np.random.default_rng(3))
    final, no_walk = _final_models(y, dt, "WN+RW", "WN")
    k = final.random_walk
    assert k.method == "bound" and k.ci95 == (0.0, k.value) and k.value >= 1e-5
    assert not final.random_walk_above_bound
    printed = final_table({"gyro_x": final})
    assert "K <" in printed and "K not identified by this 10 min record" in printed
    # the reason that applies, not a list of the possible ones
    assert "(its 95 % interval reaches zero)" in printed and ", or " not in printed
    assert "(the final model has no random walk: the long-τ AV bounds it)" in final_table({"gyro_x": no_walk})


def test_the_final_models_table_keeps_its_columns_beside_a_long_model_name():
    """A measured axis's final model (WN+MA+GM+5OSC+RW+2STEP+OUTLIERS, 31 characters) pushed its row's N, K and B
    columns past the others' (the name's column was 22 wide); the record-length lines too."""
    from dataclasses import replace

    from imu_noise_id.core.noise.components import RW, WN, simulate_sum
    from imu_noise_id.report.console import final_table, record_length_lines

    dt = 0.01
    (final,) = _final_models(simulate_sum([WN(1e-3), RW(1e-4)], 30_000, dt, np.random.default_rng(5)), dt, "WN+RW")
    long_name = "WN+MA+GM+5OSC+RW+2STEP+OUTLIERS"
    rows = final_table({"gyro_x": final, "gyro_y": replace(final, model=long_name)}).splitlines()[1:3]
    assert long_name in rows[1] and rows[0].index(" N ") == rows[1].index(" N ")
    lines = record_length_lines({"gyro_x": final.fit, "gyro_y": final.fit}, names={"gyro_y": long_name})[1:]
    assert len(lines) == 2 and lines[0].index(" now ") == lines[1].index(" now ")


def test_a_final_model_without_a_walk_gives_the_datas_long_tau_bound(tmp_path):
    """A final model without a random walk gives as K the largest walk the data's long-τ AV supports (method
    ``bound``, interval [0, bound]) with the τ range it was read over; the Allan-slope reading stays beside it as
    ``*_allan``, never in its place."""
    import yaml

    from imu_noise_id.core.allan.rw_bound import random_walk_bound
    from imu_noise_id.core.axes import AXES
    from imu_noise_id.core.simulation.static import simulate_static_imu
    from imu_noise_id.pipelines.analyze import AnalyzeOptions, ModelStage, analyze
    from imu_noise_id.report.analysis import write_analysis

    imu = simulate_static_imu({a: [WN(1e-3)] for a in AXES}, 100.0, 300.0, seed=9)
    result = analyze(imu, options=AnalyzeOptions(kinds=("allan",), models=ModelStage("WN"), loop=False, jobs=1))
    write_analysis(result, tmp_path, meta={})
    doc = yaml.safe_load((tmp_path / "imu.yaml").read_text())
    for i, axis in enumerate(("gyro_x", "gyro_y", "gyro_z")):
        bound = random_walk_bound(result.static.allan.column(i), tau_min=30.0).value
        assert doc["gyroscope_random_walk_xyz"][i] == pytest.approx(bound, rel=1e-5)
        assert doc["gyroscope_random_walk_ci_xyz"][i] == [0.0, pytest.approx(bound, rel=1e-5)]
        assert doc["gyroscope_random_walk_method_xyz"][i] == "bound"
        source = doc["gyroscope_random_walk_source_xyz"][i]
        assert "bounded by the data" in source and "at tau 31.6–150 s" in source
        assert result.finals[axis].random_walk.method == "bound"


def test_beside_a_gauss_markov_the_walk_is_bounded_not_read_from_the_bump():
    """20 min at 100 Hz of WN + GM (τ 20 s) + RW 2e-5, fitted as WN+GM (what the selection took on such records):
    K is given as a bound at or above the walk; the Allan-slope line through the GM's bump, pasted before as a point
    reading, is 4× the walk and its interval excludes it."""
    from imu_noise_id.core.allan import allan_variance
    from imu_noise_id.core.allan.slopes import fit_axis_slopes
    from imu_noise_id.core.estimation.em.model import fit_model
    from imu_noise_id.core.noise.components import GM, simulate_sum
    from imu_noise_id.pipelines.analyze.final import final_model

    dt = 0.01
    y = simulate_sum([WN(1.7e-4), GM(tau=20.0, sigma=3e-4), RW(2e-5)], 120_000, dt, np.random.default_rng(4))
    allan = allan_variance(y, dt)
    k = final_model(fit_model(y, dt, "WN+GM"), None, allan).random_walk
    assert k.method == "bound" and k.ci95 == (0.0, k.value)
    assert k.value >= 2e-5
    slope = fit_axis_slopes(allan).random_walk
    assert slope.ci[0] > 2e-5  # the reading it replaces
