"""Core repairs and stillness checks of time series (core.quality, core.stillness): pure arrays, no bags."""

from __future__ import annotations

import math

import numpy as np
import pytest
from crafted import touched

from imu_noise_id.core.axes import ImuSeries
from imu_noise_id.core.noise.modelspec import parse_imu_model
from imu_noise_id.core.quality import QualityError, repair_time_series
from imu_noise_id.core.simulation.static import simulate_static_imu
from imu_noise_id.core.stillness import StaticCheck, static_check


def _series(n: int = 1000, dt: float = 0.01, t0: float = 100.0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    return t0 + dt * np.arange(n), rng.normal(size=(n, 3))


def test_clean_series_is_returned_unchanged():
    t, x = _series()
    t2, x2, report = repair_time_series(t, x)
    assert t2 is t and x2 is x
    assert not report.repaired and report.notes() == [] and report.gaps == []
    assert report.dt == pytest.approx(0.01) and report.period.source == "median_interval"


def test_nonfinite_samples_are_dropped_and_counted():
    t, x = _series()
    x[10, 1] = np.nan
    x[20, 0] = np.inf
    t[30] = np.nan
    t2, x2, report = repair_time_series(t, x)
    assert report.n_nonfinite == 3 and len(t2) == 997
    assert np.all(np.isfinite(x2))
    assert "dropped 3 of 1000 samples with NaN/inf" in report.notes()[0]
    # The dropped samples leave 1-sample holes: reported as gaps, not hidden.
    assert len(report.gaps) == 3


def test_all_nonfinite_raises():
    t, x = _series(50)
    x[:, 0] = np.nan
    with pytest.raises(QualityError, match=r"all 50 samples have NaN/inf"):
        repair_time_series(t, x)


def test_out_of_order_stamps_are_sorted_with_the_data():
    t, x = _series()
    perm = np.arange(1000)
    perm[[100, 101]] = perm[[101, 100]]
    perm[[500, 503]] = perm[[503, 500]]
    t2, x2, report = repair_time_series(t[perm], x[perm])
    assert report.n_backwards == 3  # 101>100, then 503>501 and 502>500
    np.testing.assert_array_equal(t2, t)
    np.testing.assert_array_equal(x2, x)
    assert "sorted by stamp" in report.notes()[0]


def test_duplicated_stamps_keep_the_first_sample():
    t, x = _series()
    t_dup = np.insert(t, 201, t[200])
    x_dup = np.insert(x, 201, x[200] + 1.0, axis=0)  # the repeated stamp carries other data: still dropped
    t2, x2, report = repair_time_series(t_dup, [x_dup, x_dup[:, :1]])
    assert report.n_duplicates == 1
    np.testing.assert_array_equal(t2, t)
    np.testing.assert_array_equal(x2[0], x)  # the first of the two is kept
    assert "duplicated stamp" in report.notes()[0]


def test_gaps_are_reported_with_time_and_length():
    t, x = _series(2000, dt=0.01, t0=1000.0)
    keep = np.ones(2000, dtype=bool)
    keep[500:600] = False  # 1 s hole after t = 1004.99 s
    t2, _, report = repair_time_series(t[keep], x[keep])
    assert len(report.gaps) == 1
    start, length, missing = report.gaps[0]
    assert start == pytest.approx(1004.99) and length == pytest.approx(1.01) and missing == 100
    note = report.notes()[0]
    assert "1 gap(s)" in note and "at t=4.990 s for 1.010 s" in note and "≈100 missing" in note
    assert not report.repaired  # gaps are reported, not repaired
    assert len(t2) == 1900


def test_zero_stamps_among_clock_stamps_are_dropped_but_a_sim_time_origin_is_kept():
    t, x = _series(t0=1.7e9)
    t[[0, 7]] = 0.0
    t2, _, report = repair_time_series(t, x)
    assert report.n_zero_stamps == 2 and len(t2) == 998
    assert "zero header stamp" in report.notes()[0]
    t_sim, x_sim = _series(t0=0.0)  # simulation time starting at 0: the first stamp is legitimately 0
    _, _, report_sim = repair_time_series(t_sim, x_sim)
    assert report_sim.n_zero_stamps == 0 and not report_sim.repaired


def test_implausible_values_dropped_when_rare_and_rejected_when_many():
    t, x = _series()
    x[5, 0] = 1e200
    _, x2, report = repair_time_series(t, [x, x], max_abs=(1e3, None))
    assert report.n_implausible == 1 and np.abs(x2[0]).max() < 1e3
    assert "physically impossible" in report.notes()[0]
    x[:100, 0] = 5e3  # 10 % of samples: not corruption but wrong units → error
    with pytest.raises(QualityError, match=r"exceed the physical limits"):
        repair_time_series(t, [x, x], max_abs=(1e3, None))


def test_static_check_passes_simulated_static_imu_and_flags_motion():
    model = parse_imu_model("gyro: WN(1e-3)+RW(1e-5); accel: WN(2e-3)+RW(4e-4)")
    imu = simulate_static_imu(model, 100.0, 600.0, seed=4)
    assert static_check(imu) == StaticCheck()
    # Rotation about z at 0.2 Hz with 0.1 rad/s amplitude, and a tilt changing the gravity split on x/z.
    moving = ImuSeries(t=imu.t, gyro=imu.gyro.copy(), accel=imu.accel.copy())
    moving.gyro[:, 2] += 0.1 * np.sin(2 * np.pi * 0.2 * imu.t)
    moving.accel[:, 0] += 0.5 * np.sin(2 * np.pi * 0.05 * imu.t)
    flags = static_check(moving).flags
    assert any(f.startswith("gyro_z: the 1 s means vary") for f in flags)
    assert any(f.startswith("accel_x: the 1 s means vary") for f in flags)
    # Gravity removed (or wrong units): flagged with the reason.
    no_g = ImuSeries(t=imu.t, gyro=imu.gyro, accel=imu.accel - [0.0, 0.0, 9.80665])
    assert any("|mean accel| = 0.0" in f for f in static_check(no_g).flags)


def test_static_check_accepts_a_low_passed_and_an_uncalibrated_static_imu():
    """Issue 11/12: a static MEMS part with its DLPF on (noise 20× smoother than white) and an accelerometer
    reading |a| 3.7 % above g are static; a 0.5 Hz shake of 0.2 m/s² on top of the same data is not."""
    model = parse_imu_model("gyro: WN(1e-6)+LPF(noise_density=3e-3, cutoff=5)+RW(1e-5); "
                            "accel: WN(1e-6)+LPF(noise_density=4e-3, cutoff=5)+RW(4e-4)")
    imu = simulate_static_imu(model, 200.0, 300.0, seed=4)
    imu.accel *= 1.037
    check = static_check(imu)
    assert check.flags == [] and len(check.notes) == 1 and "+3.7 %" in check.notes[0]
    shaken = ImuSeries(t=imu.t, gyro=imu.gyro, accel=imu.accel + 0.2 * np.sin(2 * np.pi * 0.5 * imu.t)[:, None])
    assert any("|accel|" in f or "means vary" in f for f in static_check(shaken).flags)


def test_static_check_finds_a_moment_of_motion_and_suggests_the_still_stretch():
    # A 1.5 s touch near the end of a 60 s record (the record cut a moment late): the 1 s means hardly move, the
    # spread in 0.25 s windows is ~ 100× the rest's. Flagged with its time, and the still stretch ends a second
    # before it.
    model = parse_imu_model("gyro: WN(1e-3)+RW(1e-5); accel: WN(2e-3)+RW(4e-4)")
    imu = simulate_static_imu(model, 100.0, 60.0, seed=5)
    check = static_check(touched(imu, 55.0, 1.5, gyro=0.1, accel=0.2))
    burst, = check.bursts
    assert burst.start_s == pytest.approx(55.0, abs=0.25) and 55.5 <= burst.end_s <= 56.75
    assert set(burst.axes) >= {"gyro_x", "gyro_y", "accel_z"} and burst.ratio >= 25
    assert len(check.flags) == 1 and check.flags[0].startswith("motion bursts at t = 55.0–")
    assert check.still_span == pytest.approx((0.0, burst.start_s - 1.0))
    # The same touch at a tenth of the amplitude is below the threshold: not clearly motion.
    assert static_check(touched(imu, 55.0, 1.5, gyro=0.002, accel=0.004)).bursts == []


def test_static_check_leaves_spikes_steps_lines_and_coarse_quantisation_alone():
    # What a still sensor does and the loop models (OUTLIERS, OSC) is not motion: 300 isolated 30σ spikes, a
    # narrow 5 Hz line 3× the white noise; and an axis quantised at 5σ (most windows on one level) has no scale to
    # judge by.
    rng = np.random.default_rng(6)
    model = parse_imu_model("gyro: WN(1e-3)+OSC(frequency=5, bandwidth=0.05, sigma=3e-2); accel: WN(2e-3)+RW(4e-4)")
    imu = simulate_static_imu(model, 100.0, 600.0, seed=6)
    sd = 1e-3 / math.sqrt(0.01)
    imu.accel[rng.choice(imu.t.size, 300, replace=False), 0] += 30 * 2e-3 / math.sqrt(0.01) * rng.choice([-1, 1], 300)
    imu.gyro[:, 2] = 5 * sd * np.round(imu.gyro[:, 2] / (5 * sd))
    check = static_check(imu)
    assert check.bursts == [] and check.flags == [] and check.still_span is None


def test_a_stamp_far_from_both_neighbours_is_a_glitch_not_a_gap():
    """One stamp an hour in the future (or before the record) used to sort to an end and leave a 1 h gap."""
    t, x = _series()
    t[400] += 3600.0
    t[600] -= 7200.0
    t2, _, report = repair_time_series(t, x)
    assert report.n_glitches == 2 and len(t2) == 998 and report.n_backwards == 0
    assert [g[2] for g in report.gaps] == [1, 1]  # the dropped samples leave one-sample holes, not an hour
    assert "2 samples whose stamp jumps away from both neighbours" in report.notes()[0]
    t, _ = _series()
    gap = np.r_[t[:500], t[500:] + 3600.0]  # a real 1 h pause: neighbours disagree, kept as a gap
    _, _, report = repair_time_series(gap, x)
    assert report.n_glitches == 0 and len(report.gaps) == 1
