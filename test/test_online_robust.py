"""The online identification must not be poisoned by a bump, a saturated sensor or an absurd sample (issue 12).

A simulated robot (stand 10 s, drive 10 s, stand 70 s; IMU 100 Hz, odometry 20 Hz) goes through the
:class:`~imu_noise_id.pipelines.online.OnlineIdentifier` once clean and once with the damage; the published
biases must stay those of the clean run and the diagnostics must name what happened.
"""

from __future__ import annotations

import numpy as np
import pytest

from imu_noise_id.demo.online import DEMO_TRUTH, simulate_demo_run
from imu_noise_id.pipelines.online import OK, WARN, OnlineIdentifier
from imu_noise_id.pipelines.online.config import OnlineConfig

RATE = 100.0


@pytest.fixture(scope="module")
def run():
    return simulate_demo_run(3, stand_before=10.0, drive=10.0, stand_after=70.0, imu_rate=RATE, odom_rate=20.0)


class Feeder:
    """Feeds a run to an identifier in stamp order, up to a given IMU time per call, continuing where it stopped."""

    def __init__(self, run, ident: OnlineIdentifier | None = None) -> None:
        self.run, self.ident = run, ident or OnlineIdentifier()
        self.i = self.j = 0
        self.snapshots: list = []

    def until(self, t_end: float = np.inf, damage: dict[int, tuple] | None = None) -> Feeder:
        """IMU sample k replaced by ``damage[k] = (gyro, accel)``; an estimate kept every 10 s of IMU samples."""
        run, ident, damage = self.run, self.ident, damage or {}
        ni, nj = len(run.imu_t), len(run.odom_t)
        while self.i < ni and run.imu_t[self.i] <= t_end:
            i, j = self.i, self.j
            if j < nj and run.odom_t[j] < run.imu_t[i]:
                ident.process_odometry(
                    run.odom_t[j], tuple(run.linear_velocity[j]), tuple(run.angular_velocity[j]), "base", j / 20.0,
                    position=tuple(run.position[j]), orientation_xyzw=tuple(run.orientation_xyzw[j]),
                    pose_covariance=run.pose_cov[j].ravel(), twist_covariance=run.twist_cov[j].ravel())
                self.j += 1
                continue
            gyro, accel = damage.get(i, (tuple(run.gyro[i]), tuple(run.accel[i])))
            ident.process_imu(run.imu_t[i], gyro, accel, "imu", i / RATE)
            self.i += 1
            if self.i % round(10 * RATE) == 0:
                self.snapshots.append(ident.estimates())
        return self


@pytest.fixture(scope="module")
def clean(run):
    return Feeder(run).until().snapshots


def _spike(run, k: int, gyro: float = 35.0, accel: float = 157.0) -> tuple:
    g, a = run.gyro[k].copy(), run.accel[k].copy()
    g[0] += gyro
    a[0] += accel
    return tuple(g), tuple(a)


def _status(statuses, name):
    return next(s for s in statuses if s.name == name)


def test_a_single_bump_does_not_move_the_published_biases(run, clean):
    """One 35 rad/s / 157 m/s² sample (a bump at full scale) in the second stand tripled the gyro bias for
    over a minute with every status OK."""
    k = round(35 * RATE)
    feeder = Feeder(run).until(run.imu_t[k] - 0.5)
    ident = feeder.ident
    ident.diagnostics(wall_now=35.0, window_s=35.0)
    damaged = feeder.until(np.inf, {k: _spike(run, k)}).snapshots
    assert len(damaged) == len(clean) == 9 and ident.restarts == 0
    # after the spike (the first snapshot after it is at 40 s): the biases follow the clean run's
    for est, ref in zip(damaged[-5:], clean[-5:], strict=True):
        assert np.all(np.abs(est.gyro_bias - ref.gyro_bias) < 2e-4), (est.gyro_bias, ref.gyro_bias)
        assert np.all(np.abs(est.accel_bias - ref.accel_bias) < 0.01), (est.accel_bias, ref.accel_bias)
    counters = ident.cmkf_feed.estimate.counters
    assert counters["gated_gyro"] >= 1 and counters["gated_accel"] >= 1
    assert np.all(np.abs(damaged[-1].gyro_bias - np.array(DEMO_TRUTH["gyro_bias"])) < 2e-3)


def test_the_diagnostics_name_the_rejected_update(run):
    k = round(35 * RATE)
    feeder = Feeder(run).until(run.imu_t[k] - 0.5)
    ident = feeder.ident
    ident.diagnostics(wall_now=35.0, window_s=35.0)
    feeder.until(run.imu_t[k] + 0.5, {k: _spike(run, k)})
    consistency = _status(ident.diagnostics(wall_now=36.0, window_s=1.0), "Filter consistency")
    assert consistency.level == WARN and "innovation gate" in consistency.message
    assert any(key == "cmkf_gated_gyro" for key, _ in ident.pop_events())
    # and the next period is quiet again
    feeder.until(run.imu_t[k] + 1.5)
    assert _status(ident.diagnostics(wall_now=37.0, window_s=1.0), "Filter consistency").level == OK


def test_a_sensor_clipped_at_its_full_scale_is_flagged(run):
    """A bump that saturates the sensor for 30 ms: the same extreme value repeated."""
    k = round(35 * RATE)
    feeder = Feeder(run).until(run.imu_t[k] - 0.5)
    ident = feeder.ident
    ident.diagnostics(wall_now=35.0, window_s=35.0)
    clipped = {k + j: ((34.906585, *run.gyro[k + j][1:]), tuple(run.accel[k + j])) for j in range(3)}
    feeder.until(run.imu_t[k] + 0.5, clipped)
    imu = _status(ident.diagnostics(wall_now=36.0, window_s=1.0), "IMU input")
    assert imu.level == WARN and "full scale" in imu.message
    assert int(imu.values["saturated_samples"]) == 2  # the first clipped sample is the new extreme, not a repeat
    # quantised values repeating at small magnitudes are no saturation
    assert ident.imu.stats.saturated == 2


def test_a_declared_range_flags_every_sample_at_it(run):
    ident = OnlineIdentifier(OnlineConfig({"imu_range.gyro": 34.9, "imu_range.accel": 156.9}))
    g, a = run.gyro[0], run.accel[0]
    ident.process_imu(1.0, tuple(g), tuple(a))
    ident.process_imu(1.01, (34.9, *g[1:]), tuple(a))
    ident.process_imu(1.02, tuple(g), (157.0, *a[1:]))
    assert ident.imu.stats.saturated == 2


def test_the_stationarity_detector_recovers_from_absurd_samples(run):
    """1e300 overflowed the detector's variance (it never said 'still' again); 999 rad/s is accepted (below the
    plausibility limit) and must only interrupt it."""
    k = round(35 * RATE)
    feeder = Feeder(run).until(run.imu_t[k] - 0.5)
    ident = feeder.ident
    assert ident.stationarity.stationary
    damage = {k: ((1e300, 0.0, 0.0), tuple(run.accel[k])), k + 100: ((999.0, 0.0, 0.0), (0.0, 0.0, 9.0e3))}
    feeder.until(run.imu_t[k + 100] + 0.05, damage)
    assert not ident.stationarity.stationary
    feeder.until(run.imu_t[k + 100] + 15.0)
    assert ident.stationarity.stationary
    assert np.all(np.isfinite(ident.stationarity.detector._var))
