"""Header stamps that drivers get wrong must neither lock the node nor make it forget what it collected (issue 12).

Each case feeds the :class:`~imu_noise_id.pipelines.online.OnlineIdentifier` a still IMU (white noise of known
per-sample σ) whose stamps are damaged, and checks that the rate is learnt, the good messages are used, the noise
identification goes on and the corrected IMU's covariance is right.
"""

from __future__ import annotations

import numpy as np
import pytest

from imu_noise_id.demo.online import simulate_demo_run
from imu_noise_id.pipelines.online import OnlineIdentifier

SIGMA_G, SIGMA_A = 1e-3, 1e-2  # per-sample standard deviations [rad/s], [m/s²]


def still(ident: OnlineIdentifier, stamps, seed: int = 0) -> list:
    """A still IMU at the given stamps; the corrected samples released."""
    rng = np.random.default_rng(seed)
    out = []
    for t in stamps:
        out += ident.process_imu(float(t), tuple(rng.normal(0, SIGMA_G, 3)),
                                 tuple(rng.normal(0, SIGMA_A, 3) + np.array([0.0, 0.0, 9.81])))
    return out


def _covariance_is_right(ident: OnlineIdentifier) -> None:
    est = ident.estimates()
    assert est.covariance_source == "stationary"
    np.testing.assert_allclose(est.covariance, [SIGMA_G**2] * 3 + [SIGMA_A**2] * 3, rtol=0.15)


def test_an_isolated_future_stamp_is_rejected_without_its_neighbours():
    """One stamp an hour ahead dropped the next 49 good messages, and then a restart erased the noise samples."""
    stamps = 1.0 + 0.01 * np.arange(3000)
    stamps[1500] += 3600.0
    ident = OnlineIdentifier()
    out = still(ident, stamps[:1500])
    n_before = ident.noise.n
    out += still(ident, stamps[1500:], seed=1)
    assert len(out) == 2999 and ident.imu.stats.accepted == 2999
    assert ident.imu.stamps.counts["outlier"] == 1 and ident.restarts == 0
    assert ident.noise.n > n_before + 1000
    assert ident.imu.stamps.rate == pytest.approx(100.0, rel=0.01)
    _covariance_is_right(ident)


def test_an_isolated_backward_stamp_is_dropped_alone():
    stamps = list(1.0 + 0.01 * np.arange(2000))
    stamps[1000] = 0.5
    ident = OnlineIdentifier()
    out = still(ident, stamps)
    assert len(out) == 1999 and ident.imu.stamps.counts["backward"] == 1 and ident.restarts == 0


def test_a_restarted_source_keeps_what_was_collected():
    """The stamps jump back and go on from there (a driver restarted, a bag played again): a new time line."""
    ident = OnlineIdentifier()
    still(ident, 100.0 + 0.01 * np.arange(3000))
    n_before = ident.noise.n
    density_before = ident.estimates().noise_density
    out = still(ident, 1.0 + 0.01 * np.arange(3000), seed=1)
    assert ident.restarts == 1
    assert len(out) >= 3000 - ident.config.backward_reset_count
    assert ident.noise.n > n_before + 2000  # nothing forgotten, and the identification goes on
    np.testing.assert_allclose(ident.estimates().noise_density, density_before, rtol=0.1)
    _covariance_is_right(ident)


def test_a_restarted_robot_keeps_its_biases():
    run = simulate_demo_run(3, stand_before=10.0, drive=10.0, stand_after=20.0, imu_rate=100.0, odom_rate=20.0)
    ident = OnlineIdentifier()

    def play(shift: float) -> None:
        i = j = 0
        while i < len(run.imu_t):
            if j < len(run.odom_t) and run.odom_t[j] < run.imu_t[i]:
                ident.process_odometry(run.odom_t[j] + shift, tuple(run.linear_velocity[j]),
                                       tuple(run.angular_velocity[j]), "base",
                                       twist_covariance=run.twist_cov[j].ravel(),
                                       orientation_xyzw=tuple(run.orientation_xyzw[j]))
                j += 1
            else:
                ident.process_imu(run.imu_t[i] + shift, tuple(run.gyro[i]), tuple(run.accel[i]))
                i += 1
                if i == 300 and shift < 0:  # 3 s into the second play: the filter has restarted on the new line
                    after = ident.estimates()  # the biases went on from where they were (not the prior 0 ± σ)
                    assert np.all(np.abs(after.gyro_bias - before.gyro_bias) < 3 * before.gyro_bias_std)
                    assert np.all(np.abs(after.accel_bias - before.accel_bias) < 3 * before.accel_bias_std)
                    assert np.all(after.gyro_bias_std < 2 * before.gyro_bias_std)

    play(0.0)
    before = ident.estimates()
    play(-900.0)
    assert ident.restarts == 1 and ident.cmkf_feed.estimate.status == "tracking"
    assert ident.odom.stamps.counts["restart"] == 1


def test_bursts_of_host_stamped_messages_keep_the_rate():
    """A USB driver stamps on arrival: 20 messages 0.1 ms apart every 200 ms (100 Hz on average)."""
    stamps = (1.0 + 0.2 * np.arange(150)[:, None] + 1e-4 * np.arange(20)[None, :]).ravel()
    ident = OnlineIdentifier()
    out = still(ident, stamps)
    assert len(out) >= len(stamps) - 1
    assert ident.imu.stamps.rate == pytest.approx(100.0, rel=0.05)
    assert ident.noise.n > 0.7 * len(stamps)
    _covariance_is_right(ident)
    # the density is in the nominal period's units, not the burst spacing's
    np.testing.assert_allclose(ident.estimates().noise_density[:3], SIGMA_G * np.sqrt(0.01), rtol=0.15)


def test_a_first_interval_of_a_microsecond_is_forgotten():
    stamps = np.concatenate([[1.0], 1.000001 + 0.01 * np.arange(3000)])
    ident = OnlineIdentifier()
    out = still(ident, stamps)
    assert len(out) >= len(stamps) - 1
    assert ident.imu.stamps.rate == pytest.approx(100.0, rel=0.01)
    assert ident.noise.n > 2000
    _covariance_is_right(ident)


def test_a_rate_drop_by_more_than_the_gap_factor_is_relearned():
    """100 Hz, then 5 Hz: every interval was a gap and the identification stopped for good."""
    stamps = np.concatenate([1.0 + 0.01 * np.arange(2000), 21.0 + 0.2 * np.arange(1, 400)])
    ident = OnlineIdentifier()
    still(ident, stamps[:2000])
    n_fast = ident.noise.n
    out = still(ident, stamps[2000:], seed=1)
    assert len(out) >= 398
    assert ident.imu.stamps.rate == pytest.approx(5.0, rel=0.01)
    assert ident.noise.n > n_fast + 300  # the 5 Hz samples are identified too
    assert ident.estimates().covariance_source == "stationary"
