"""Allan-family variances: equality with allantools, the ADIS16405 reference curve, EDF, CI coverage, bad input."""

from __future__ import annotations

import csv
import math

import allantools
import numpy as np
import pytest
from allantools import ci as at_ci

from imu_noise_id.core import allan
from imu_noise_id.core.errors import InputError
from imu_noise_id.core.noise.components import RW, WN

ALLANTOOLS = {"allan": allantools.oadev, "hadamard": allantools.ohdev, "total": allantools.totdev,
              "modified": allantools.mdev}
DT = 0.01


@pytest.fixture(scope="module")
def six_axes() -> np.ndarray:
    """6 axes of WN + RW with large offsets (like gravity on accel_z) and different scales."""
    rng = np.random.default_rng(7)
    n = 6000
    scale = np.array([1e-3, 2e-3, 5e-4, 1e-2, 2e-2, 3e-2])
    walk = np.cumsum(rng.standard_normal((n, 6)), axis=0) * scale * 0.02
    offset = np.array([0.01, -0.02, 0.003, 0.1, -0.2, 9.81])
    return rng.standard_normal((n, 6)) * scale + walk + offset


@pytest.mark.parametrize("kind", allan.KINDS)
def test_equals_allantools_six_axes(kind, six_axes):
    """Same numbers as allantools (freq data, same rate and τ) to a relative 1e-9, every axis, default τ grid."""
    res = allan.allan_family(six_axes, DT, kind)
    assert res.variance.shape == (res.tau.size, 6)
    assert res.tau.size > 20
    for j in range(6):
        taus, dev, _, _ = ALLANTOOLS[kind](six_axes[:, j], rate=1 / DT, data_type="freq", taus=res.tau)
        np.testing.assert_allclose(taus, res.tau, rtol=1e-12)
        np.testing.assert_allclose(res.variance[:, j], dev**2, rtol=1e-9, atol=0)


@pytest.mark.parametrize("kind", allan.KINDS)
def test_equals_allantools_1d_explicit_tau(kind, six_axes):
    """1-D input with explicit τ, including the longest τ the estimator allows."""
    y = six_axes[:, 3]
    longest = allan.max_m(y.size, kind) * DT
    tau = np.array([DT, 0.05, 0.37, 2.0, 11.1, longest])
    res = allan.allan_family(y, DT, kind, tau=tau)
    assert res.variance.shape == (tau.size, 1)
    _, dev, _, _ = ALLANTOOLS[kind](y, rate=1 / DT, data_type="freq", taus=res.tau)
    np.testing.assert_allclose(res.variance[:, 0], dev**2, rtol=1e-9, atol=0)


def test_modified_equals_allan_at_m1(six_axes):
    """MAV averages the phase over m samples: for m = 1 it is the AV (NIST SP1065 eq. 14)."""
    av = allan.allan_variance(six_axes, DT, m=[1]).variance
    mav = allan.modified_allan_variance(six_axes, DT, m=[1]).variance
    # The estimators differ only in the count of terms (N − 1 vs N − 1 for m = 1): identical.
    np.testing.assert_allclose(mav, av, rtol=1e-12)


def test_adis16405_matches_reference_curve(shared_data):
    """AV of ADIS16405 run 1 equals the avar package's `adis_av` (deg/s and g) at its 18 dyadic τ, 6 axes.

    Tolerance 2e-5 relative: the data README measures ≈6e-6 (the reference was computed in single steps by
    another implementation and stored with limited precision).
    """
    data = np.load(shared_data / "adis16405_static" / "adis16405_run1.npz")
    fs = float(data["fs_hz"])
    gyro_deg = data["gyro"] * 180.0 / np.pi
    accel_g = data["accel"] / 9.80665
    with open(shared_data / "smac_reference_allan" / "reference_allan_variances.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["object"] == "adis_av"]
    checked = 0
    for sensor, samples in (("Gyroscope", gyro_deg), ("Accelerometer", accel_g)):
        for j, axis in enumerate("XYZ"):
            ref = sorted((float(r["tau_s"]), float(r["avar"])) for r in rows
                         if r["sensor_type"] == sensor and r["axis"] == axis)
            tau = np.array([t for t, _ in ref])
            res = allan.allan_variance(samples[:, j], 1.0 / fs, tau=tau, alpha=0)
            np.testing.assert_allclose(res.variance[:, 0], [v for _, v in ref], rtol=2e-5)
            checked += tau.size
    assert checked == 6 * 18


@pytest.mark.parametrize(("d", "modified"), [(2, False), (3, False), (2, True)])
def test_greenhall_edf_equals_allantools(d, modified):
    """Our Greenhall EDF (all cases 1–4 we reach) equals allantools' independent implementation."""
    n_phase = 20001
    for alpha in (2, 1, 0, -1, -2):
        for m in (1, 2, 5, 30, 100, 1000, 4000):
            try:
                ref = at_ci.edf_greenhall(alpha, d, m, n_phase, overlapping=True, modified=modified)
            except NotImplementedError:
                continue  # allantools lacks case 4 with few differences; covered by our exact sum
            ours = allan.edf_greenhall(alpha, d, m, n_phase, overlapping=True, modified=modified)
            assert ours == pytest.approx(ref, rel=1e-9), (alpha, m)


def test_total_edf_matches_sp1065_table():
    for alpha in (0, -1, -2):
        assert allan.edf_total(alpha, 10, 10000) == pytest.approx(at_ci.edf_totdev(10000, 10, alpha), rel=1e-12)


def _coverage(y: np.ndarray, dt: float, m: int, truth: float) -> float:
    res = allan.allan_variance(y, dt)
    i = int(np.flatnonzero(res.m == m)[0])
    return float(np.mean((res.ci_low[i] <= truth) & (truth <= res.ci_high[i])))


def test_ci_coverage_white_noise():
    """For white noise the true AV σ²/m lies in the 95 % CI in ≈95 % of 400 seeded series (noise type found
    from the curve). Binomial sd of the rate is 1.1 %: accept 0.91–0.985."""
    rng = np.random.default_rng(11)
    y = rng.standard_normal((4000, 400))
    m = 18
    truth = WN(math.sqrt(DT)).allan_variance(m * DT, DT)  # unit per-sample variance
    assert 0.91 <= _coverage(y, DT, m, float(truth)) <= 0.985


def test_ci_coverage_random_walk():
    """Same for a random walk (α = −2) at a mid τ, where the EDF is small (≈10)."""
    rng = np.random.default_rng(12)
    k = 1e-3
    y = np.cumsum(rng.standard_normal((4000, 400)) * k * math.sqrt(DT), axis=0)
    m = 178
    truth = float(RW(k).allan_variance(m * DT, DT))
    assert 0.91 <= _coverage(y, DT, m, truth) <= 0.985


def test_choose_m_log_spaced_unique_and_bounded():
    for kind in allan.KINDS:
        m = allan.choose_m(100000, kind, per_decade=5)
        assert m[0] == 1 and m[-1] == allan.max_m(100000, kind)
        assert np.all(np.diff(m) > 0)
        per_decade = np.histogram(np.log10(m), bins=np.arange(0, 6))[0]
        assert np.all(per_decade[:4] <= 6)


@pytest.mark.parametrize(
    ("y", "kwargs", "match"),
    [
        (np.ones(2), {}, "too few"),
        (np.array([0.0, 1.0, np.nan, 2.0, 3.0]), {}, "NaN"),
        (np.r_[np.zeros(50), np.inf], {}, "NaN/inf"),
        (np.zeros(100), {"tau": [0.6]}, "beyond the longest"),
        (np.zeros(100), {"tau": [0.001]}, "shorter than the sampling period"),
        (np.zeros(100), {"m": [0]}, "integers >= 1"),
        (np.zeros(100), {"tau": [0.1], "m": [1]}, "either tau or m"),
        (np.zeros((100, 2, 2)), {}, "shape"),
    ],
)
def test_bad_input_gives_clear_error(y, kwargs, match):
    with pytest.raises(InputError, match=match):
        allan.allan_variance(y, DT, **kwargs)


def test_bad_dt_kind_confidence():
    y = np.random.default_rng(0).standard_normal(100)
    with pytest.raises(InputError, match="dt"):
        allan.allan_variance(y, 0.0)
    with pytest.raises(InputError, match="kind"):
        allan.allan_family(y, DT, "bogus")
    with pytest.raises(InputError, match="confidence"):
        allan.allan_variance(y, DT, confidence=1.5)


def test_stack_axes_equals_joint_computation(six_axes):
    """Computing gyro and accel blocks separately and stacking gives exactly the joint (N, 6) result."""
    joint = allan.total_variance(six_axes, DT)
    parts = allan.stack_axes([allan.total_variance(six_axes[:, :3], DT), allan.total_variance(six_axes[:, 3:], DT)])
    for name in ("variance", "ci_low", "ci_high", "edf", "alpha"):
        np.testing.assert_array_equal(getattr(parts, name), getattr(joint, name))
    with pytest.raises(ValueError, match="differ"):
        allan.stack_axes([joint, allan.allan_variance(six_axes, DT)])
