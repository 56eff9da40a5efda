"""An axis whose final model is not trusted never pastes a component value as identified: method ``unresolved``,
the overbound's N and K (upper bounds), the reason in every output."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
import yaml
from scipy import signal

from imu_noise_id.core.allan.slopes import SlopeComponent
from imu_noise_id.core.axes import AXES, GYRO_AXES
from imu_noise_id.core.estimation.readouts.kalibr import KalibrValue
from imu_noise_id.core.estimation.readouts.passband import PassbandLevel, passband_level
from imu_noise_id.core.noise.components import RW, WN
from imu_noise_id.core.simulation.static import simulate_static_imu
from imu_noise_id.pipelines.analyze import AnalyzeOptions, ModelStage, analyze
from imu_noise_id.pipelines.analyze.overbound import data_overbound
from imu_noise_id.pipelines.analyze.resolution import (
    PASSBAND_FACTOR,
    PASSBAND_TOLERANCE,
    passband_confirms,
    passband_disagreement,
    resolve_axis,
    resolved,
    unresolved_reason,
)
from imu_noise_id.report.analysis import write_analysis
from imu_noise_id.report.console import final_table

RATE = 200.0
PASSBAND = 1e-3  # m/s²/√Hz, the white noise's density before the sensor's second-order low-pass
#: The gyro axis the fixture analyses: it stands for the axes whose loop passes (accel_y is the filtered one).
PASSING = "gyro_x"


def _level(result, imu, axis: str) -> PassbandLevel | None:
    """The record's passband level in the final model's band, as analyze reads it for the resolution."""
    return passband_level(imu.axis(axis), result.static.dt, list(result.finals[axis].fit.components))


def _reading(value: float, ci: tuple[float, float], method: str = "fit") -> SlopeComponent:
    return SlopeComponent("WN", -1.0, value**2, value, ci, method, (0.1, 10.0), 12)


@pytest.mark.parametrize(("n", "ci", "disagrees"), [
    (8.1e-10, (0.0, 7e-7), True),  # a white noise driven to ~0 beside the process that took the passband
    (1.02e-3, (1.0e-3, 1.04e-3), False),  # within the reading's interval
    (1.3e-3, (1.29e-3, 1.31e-3), False),  # intervals disjoint, but within the practical factor
    (2.5e-3, (2.4e-3, 2.6e-3), True),  # above it by more than the factor
    (1e-3, (math.nan, math.nan), False),  # no interval: the value itself, within
])
def test_passband_disagreement_needs_disjoint_intervals_and_the_factor(n, ci, disagrees):
    reading = _reading(1.0e-3, (0.97e-3, 1.03e-3))
    why = passband_disagreement(KalibrValue(n, ci, "WN"), reading)
    assert (why is not None) is disagrees
    if disagrees:
        assert f"{n / 1e-3:.3g} times the data's white-noise line" in why


def test_an_upper_bound_reading_disagrees_only_with_an_n_above_it():
    bound = _reading(8e-5, (0.0, 8e-5), method="upper_bound")
    assert passband_disagreement(KalibrValue(8e-10, (0.0, 7e-7), "WN"), bound) is None
    assert passband_disagreement(KalibrValue(PASSBAND_FACTOR * 1e-4, (1.9e-4, 2.1e-4), "WN"), bound) is not None


def _passing(result) -> str:
    """:data:`PASSING`, whose loop the tests below take to have passed."""
    assert result.loops[PASSING].passed
    return PASSING


@pytest.fixture(scope="module")
def filtered(tmp_path_factory):
    """5 min at 200 Hz: accel_y's white noise through a digital 2nd-order Butterworth low-pass at 12 Hz (a consumer
    part's DLPF) with no white floor after it, the other axes WN + RW; the structure given, WN+GM (as the model
    selection chose before it offered the DLPF): the GM takes accel_y's filtered noise beside a white noise driven
    to ~0 (N ≈ 8·10⁻¹⁰), and the loop's verdict fails."""
    model = {a: [WN(1.7e-4), RW(2e-5)] if a in GYRO_AXES else [WN(2e-3), RW(3e-4)] for a in AXES}
    imu = simulate_static_imu(model, RATE, 300.0, seed=52)
    rng = np.random.default_rng(52)
    white = rng.standard_normal(imu.t.size + 2000) * PASSBAND * math.sqrt(RATE)
    accel = imu.accel.copy()
    accel[:, 1] = signal.sosfilt(signal.butter(2, 12.0, fs=RATE, output="sos"), white)[2000:]
    imu = replace(imu, accel=accel)
    result = analyze(imu, options=AnalyzeOptions(models=ModelStage("WN+GM"), jobs=1, axes=(PASSING, "accel_y")))
    out = tmp_path_factory.mktemp("filtered")
    write_analysis(result, out, meta={})
    return result, out, imu


def test_a_failed_verdict_pastes_the_overbound_as_unresolved(filtered):
    result, out, _ = filtered
    final = result.finals["accel_y"]
    assert not result.loops["accel_y"].passed
    assert final.unresolved is not None and "verdict failed" in final.unresolved
    assert final.noise_density.method == final.random_walk.method == "unresolved"
    overbound = result.overbounds["accel_y"]
    assert (final.noise_density.value, final.random_walk.value) == (overbound.noise_density, overbound.random_walk)
    assert overbound.inflation_noise_density == overbound.inflation_random_walk == 1.0
    # an upper bound on the passband level, never a value 10⁶ below it, and not inflated by the untrusted model
    assert PASSBAND <= final.noise_density.value <= 1.5 * PASSBAND
    assert final.model_values[0].value < 1e-3 * PASSBAND  # the model's own, kept in model.yaml
    doc = yaml.safe_load((out / "imu.yaml").read_text())
    assert doc["accelerometer_noise_density_method_xyz"][1] == "unresolved"
    assert doc["accelerometer_noise_density_xyz"][1] == pytest.approx(final.noise_density.value, rel=1e-5)
    assert doc["accelerometer_noise_density_ci_xyz"][1][0] == 0.0
    assert doc["accelerometer_noise_density"] >= doc["accelerometer_noise_density_xyz"][1]
    assert "accel_y  N and K unresolved" in final_table(result.finals)
    entry = yaml.safe_load((out / "model.yaml").read_text())
    assert "model_values" in str(entry)


def test_resolved_axes_keep_their_model_values(filtered):
    result, out, _ = filtered
    doc = yaml.safe_load((out / "imu.yaml").read_text())
    axis = _passing(result)
    assert result.finals[axis].unresolved is None
    assert doc["gyroscope_noise_density_method_xyz"][GYRO_AXES.index(axis)] == "model"
    assert result.finals[axis].noise_density.value == pytest.approx(1.7e-4, rel=0.05)


@pytest.mark.parametrize(("n", "reading", "confirms"), [
    (1.02e-3, _reading(1.0e-3, (0.97e-3, 1.03e-3)), True),
    (1.04e-3, _reading(1.0e-3, (0.97e-3, 1.03e-3)), False),  # outside the line's interval, though within the factor
    (1.025e-3, _reading(1.0e-3, (0.995e-3, 1.005e-3)), True),  # a long record's narrow interval: within the tolerance
    (0.965e-3, _reading(1.0e-3, (0.995e-3, 1.005e-3)), False),  # beyond the tolerance
    (5e-5, _reading(8e-5, (0.0, 8e-5), method="upper_bound"), False),  # a bound reads no level
    (None, _reading(1.0e-3, (0.97e-3, 1.03e-3)), False),
])
def test_the_white_noise_line_confirms_an_n_inside_its_interval(n, reading, confirms):
    assert passband_confirms(KalibrValue(n, (math.nan, math.nan), "WN"), reading) is confirms


def test_a_failed_verdict_keeps_an_n_the_data_confirm_and_gives_the_overbound_k(filtered):
    """A right structure whose verdict fails (as one τ outside a 95 % band does on some records by chance) keeps the
    model's N where the white-noise line, read without the model, confirms it; K is the overbound's, unresolved."""
    result, _, _ = filtered
    axis = _passing(result)
    final, static = result.finals[axis], result.static
    reading = static.slopes[axis].noise_density
    assert passband_confirms(final.noise_density, reading)
    failed = replace(result.loops[axis], passed=False, verdict="AV misfit left unexplained (at one τ)")
    why = unresolved_reason(final, failed, reading)
    assert why is not None and why.noise_density_kept
    given = resolved(final, why, data_overbound(static, axis))
    assert given.noise_density.method == "model"
    assert given.noise_density.value == final.noise_density.value
    assert given.noise_density.ci95 == final.noise_density.ci95
    assert "white-noise line" in given.noise_density.source
    assert given.random_walk.method == "unresolved"
    assert given.random_walk.value == data_overbound(static, axis).random_walk
    assert given.model_values == (final.noise_density, final.random_walk)
    assert f"{axis:8s} K unresolved" in final_table({axis: given})


def test_an_n_a_few_percent_off_a_narrow_level_is_kept_with_an_interval_spanning_both(filtered):
    """On a whole record the data's passband level is read to a fraction of a percent, and a model whose verdict
    fails (its N 2.5 % off, as on whole ADIS16405 accelerometer axes) pasted the overbound's N, 1.5–1.7× the level:
    within :data:`PASSBAND_TOLERANCE` the model's N is kept, its interval the hull of its own and the level's."""
    assert 0.025 <= PASSBAND_TOLERANCE < 0.05  # the two cases below lie on either side of it
    result, _, _ = filtered
    axis = _passing(result)
    final, static = result.finals[axis], result.static
    n = final.noise_density
    level = _reading(n.value / 1.025, (n.value / 1.03, n.value / 1.02))  # the model 2.5 % above, outside the interval
    failed = replace(result.loops[axis], passed=False, verdict="stopped after 8 added effects")
    why = unresolved_reason(final, failed, level)
    assert why is not None and why.noise_density_kept
    given = resolved(final, why, data_overbound(static, axis)).noise_density
    assert given.method == "model" and given.value == n.value
    assert given.ci95[0] <= level.ci[0] and given.ci95[1] >= n.ci95[1] and given.ci95[0] <= level.value
    assert "within 2.5 % of the data's white-noise line" in given.source and "spans both" in given.source
    far = _reading(n.value / 1.05, (n.value / 1.055, n.value / 1.045))  # 5 % off: the overbound stands
    assert not unresolved_reason(final, failed, far).noise_density_kept


def test_an_n_far_from_the_line_is_not_kept_whatever_the_verdict(filtered):
    result, _, _ = filtered
    final = result.finals["accel_y"]
    assert final.noise_density.method == "unresolved"  # the model's N 10⁶ below the passband is not confirmed
    assert not passband_confirms(final.model_values[0], result.static.slopes["accel_y"].noise_density)


def test_the_analysis_confirms_a_kept_n_by_the_records_spectrum(filtered):
    """What analyze runs on a failed verdict: the passband level read from the record's spectrum, in the band the
    model's white noise dominates, confirms the right N; the warning and the source name it."""
    result, _, imu = filtered
    axis = _passing(result)
    failed = replace(result.loops[axis], passed=False, verdict="AV misfit left unexplained (at one τ)")
    level = _level(result, imu, axis)
    given, overbound, warning = resolve_axis(result.finals[axis], failed, result.static, axis, level, horizon_s=100.0)
    assert given.noise_density.method == "model" and given.random_walk.method == "unresolved"
    assert "record's spectrum" in given.noise_density.source and "K unresolved" in warning
    assert overbound.reference_noise_density == given.noise_density.value
    assert resolve_axis(result.finals[axis], result.loops[axis], result.static, axis, level, horizon_s=100.0) is None


def test_a_white_noise_line_read_off_the_floor_after_the_filter_is_no_disagreement_the_spectrum_refutes(filtered):
    """Behind a sensor's low-pass with a white floor after it, the AV holds two white-noise lines: the floor's at the
    shortest τ and the passband's beyond the filter's roll-off; where the roll-off ends too slowly for the slope
    reader (a 2nd-order 5 Hz filter at 1 kHz, on some records), its line is the floor's, ~10× below the passband.
    The model's N, which the record's spectrum confirms, does not disagree with the data then: the passband level
    decides wherever it reads, the AV line only where it does not."""
    result, _, imu = filtered
    axis = _passing(result)
    final, static = result.finals[axis], result.static
    n = final.noise_density.value
    floor = _reading(n / 11.7, (n / 12.6, n / 10.9))  # disjoint from the model's N and 11.7× below it
    assert passband_disagreement(final.noise_density, floor) is not None
    slopes = replace(static.slopes[axis], noise_density=floor)
    on_floor = replace(static, slopes={**static.slopes, axis: slopes})
    level = _level(result, imu, axis)
    assert resolve_axis(final, result.loops[axis], on_floor, axis, level, horizon_s=100.0) is None
    failed = replace(result.loops[axis], passed=False, verdict="AV misfit left unexplained (at one τ)")
    given, _, warning = resolve_axis(final, failed, on_floor, axis, level, horizon_s=100.0)
    assert given.noise_density.method == "model" and given.noise_density.value == n
    assert "record's spectrum" in given.noise_density.source and "K unresolved" in warning
    # a model N the spectrum refutes still disagrees, whatever the line
    low = replace(final, noise_density=replace(final.noise_density, value=n / 3, ci95=(n / 3.1, n / 2.9)))
    given, _, warning = resolve_axis(low, result.loops[axis], on_floor, axis, level, horizon_s=100.0)
    assert given.noise_density.method == "unresolved" and "record's spectrum" in warning
