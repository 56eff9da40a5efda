"""The offline replay (``imu-noise-id cmkf``) is the node's identifier fed a recording: on a crafted recording that the
bare filter gets wrong, the replay's estimates equal those of an ``OnlineIdentifier`` made from the node's parameters
and fed the same messages, and its whole-run verdict is the node's verdict over the whole run."""

from __future__ import annotations

import numpy as np
import pytest

from imu_noise_id.core.axes import ImuSeries, OdometrySeries
from imu_noise_id.core.cmkf.config import CmkfConfig
from imu_noise_id.core.cmkf.estimate import judge
from imu_noise_id.core.cmkf.robot import RobotCmkf
from imu_noise_id.core.cmkf.stream import feed_recording
from imu_noise_id.core.simulation.robot import simulate_robot
from imu_noise_id.pipelines.cmkf_replay import replay, run_window
from imu_noise_id.pipelines.online import OnlineConfig, OnlineIdentifier

T0 = 100.0


@pytest.fixture(scope="module")
def crafted():
    """A simulated robot (60 s, IMU 100 Hz, odometry 10 Hz) with what a node meets: an implausible IMU sample
    (2e4 m/s²: the node drops it, the bare filter integrates it), a NaN gyro sample, a 1.5 s IMU gap and an odometry
    message repeated with its stamp."""
    run = simulate_robot(60.0, np.random.default_rng(5))
    t, gyro, accel = run.imu_t + T0, run.gyro.copy(), run.accel.copy()
    accel[2500] = (2e4, 0.0, 0.0)
    gyro[3000, 1] = np.nan
    keep = np.ones(t.size, dtype=bool)
    keep[4000:4150] = False
    imu = ImuSeries(t[keep], gyro[keep], accel[keep], frame_id="imu_link")
    order = np.insert(np.arange(run.odom_t.size), 300, 300)
    odom = OdometrySeries(run.odom_t[order] + T0, run.position[order], run.orientation_xyzw[order],
                          run.linear_velocity[order], run.angular_velocity[order], run.pose_cov[order],
                          run.twist_cov[order])
    return run, imu, odom


def _node(run, imu: ImuSeries, odom: OdometrySeries) -> OnlineIdentifier:
    """An identifier made from the node's parameters (CmkfConfig's defaults, the core's stamp-merger latency), fed
    every message in stamp order (IMU first on equal stamps) as the node's callbacks would, to the end."""
    ident = OnlineIdentifier(OnlineConfig({"cmkf.imu_rotation_xyzw": run.imu_rotation_xyzw,
                                           "cmkf.input_latency": CmkfConfig().late_odom_tolerance}))
    messages = sorted([(t, 0, k) for k, t in enumerate(imu.t)] + [(t, 1, k) for k, t in enumerate(odom.t)])
    for t, is_odometry, k in messages:
        if is_odometry:
            ident.process_odometry(t, tuple(odom.linear_velocity[k]), tuple(odom.angular_velocity[k]),
                                   position=tuple(odom.position[k]), orientation_xyzw=tuple(odom.orientation_xyzw[k]),
                                   pose_covariance=odom.pose_covariance[k].ravel(),
                                   twist_covariance=odom.twist_covariance[k].ravel())
        else:
            ident.process_imu(t, tuple(imu.gyro[k]), tuple(imu.accel[k]))
    ident.finish()
    ident.update_identification()  # the node's publishing step: the estimate re-read
    return ident


def test_the_replay_gives_the_node_identifiers_estimates(crafted):
    run, imu, odom = crafted
    result = replay(imu, odom, CmkfConfig(imu_rotation_xyzw=run.imu_rotation_xyzw))
    node = _node(run, imu, odom)
    published = node.estimates()
    final = result.final
    for name in ("gyro_bias", "gyro_bias_std", "accel_bias", "accel_bias_std"):
        np.testing.assert_array_equal(getattr(published, name), getattr(final, name), err_msg=name)
    psd = np.concatenate([final.gyro_psd.value, final.accel_psd.value])
    identified = np.concatenate([final.gyro_psd.identified, final.accel_psd.identified])
    np.testing.assert_array_equal(published.psd, np.where(identified, psd, np.nan))
    np.testing.assert_array_equal(published.psd_se, np.concatenate([final.gyro_psd.se, final.accel_psd.se]))
    estimate = node.cmkf_feed.estimate
    assert (estimate.status, estimate.counters, estimate.n_stacked) == (final.status, final.counters, final.n_stacked)
    assert estimate.nis_accel_mean == final.nis_accel_mean and estimate.consistency == final.consistency
    assert result.t.size == node.odom.stats.accepted == odom.t.size - 1  # the repeated message: dropped before the CMKF
    # the recording discriminates: fed to the bare filter, the implausible sample moves the estimates
    bare = RobotCmkf(result.config)
    for _ in feed_recording(bare, imu, odom):
        pass
    bare_estimate = bare.estimate()
    assert bare_estimate.counters["imu_dropped_nan"] == 1 and final.counters["imu_dropped_nan"] == 0
    assert not np.allclose(bare_estimate.accel_bias, final.accel_bias, rtol=1e-6, atol=0.0)


def test_the_whole_run_verdict_is_the_nodes_verdict_over_the_whole_run(crafted):
    """With a NIS window longer than the run, the node's verdict (RobotCmkf's windows) and the replay's whole-run
    verdict (its recorded NIS, none skipped) are one judgement of the same updates."""
    run, imu, odom = crafted
    result = replay(imu, odom, CmkfConfig(imu_rotation_xyzw=run.imu_rotation_xyzw, nis_window=10**6))
    final = result.final
    windows = [run_window(result.nis_accel, final.nis_accel_dof, result.gated_accel, skip_fraction=0.0)[0],
               run_window(result.nis_gyro, final.nis_gyro_dof, result.gated_gyro, skip_fraction=0.0)[0]]
    assert judge(windows)[0] == final.consistency
    assert (windows[0].mean, windows[1].mean) == (final.nis_accel_mean, final.nis_gyro_mean)
    assert windows[0].n > 400 and windows[1].n > 400
