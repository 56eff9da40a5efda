"""Tests of the covariance matching Kalman filter (paper 004) and its robot generalisation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from reference_cmkf import (
    PaperCmkf,
    TurntableConfig,
    simulate_turntable,
    turntable_monte_carlo,
)

from imu_noise_id.core.cmkf.axis import AxisCmkf, paper_interval
from imu_noise_id.core.cmkf.config import CmkfConfig
from imu_noise_id.core.cmkf.robot import RobotCmkf
from imu_noise_id.core.cmkf.stacked import cov_z_model
from imu_noise_id.core.cmkf.stream import CmkfStream
from imu_noise_id.core.simulation.robot import replay_arrays, simulate_robot

G = 9.80665


def _paper_filter(cfg: TurntableConfig, z0: np.ndarray, pd_check: str = "joint") -> PaperCmkf:
    x0 = np.array([z0[0], z0[1], 0.0, z0[2], z0[3], 0.0])
    P0 = np.diag([cfg.R_diag[0], cfg.R_diag[1], cfg.sigma_ss**2] * 2)
    return PaperCmkf(cfg.T, cfg.tau, cfg.q_b, np.diag(cfg.R_diag), cfg.S_v0, x0=x0, P0=P0, pd_check=pd_check)


def test_cov_z_model_matches_sample_covariance():
    """Eqs. (34)–(35) with A₁ = −M_o†M_v, A₂ = F̂M_o†M_v − I predict the sample covariance of simulated 𝒵.

    A larger S_v than the paper's makes the S_v term visible; 20 000 samples of an MA(2) sequence give relative
    standard errors of ~2 % on the variances: tolerance 8 % (4σ) on the diagonal, 0.06 on the correlations.
    """
    cfg = TurntableConfig(S_v=1e-3)
    run = simulate_turntable(cfg, 2000.0, np.random.default_rng(11))
    pf = _paper_filter(cfg, run.z[0])
    Z = []
    for k in range(len(run.dv)):
        pf.predict(run.dv[k])
        pf.update(run.z[k + 1])
        if pf.count:
            Z.append(pf.stacked_sample())
    Z = np.array(Z)
    sample = Z.T @ Z / len(Z)
    model = pf.cov_Z_model(np.array([cfg.S_v, cfg.S_v]))
    np.testing.assert_allclose(np.diag(sample), np.diag(model), rtol=0.08)
    corr = lambda C: C / np.sqrt(np.outer(np.diag(C), np.diag(C)))  # noqa: E731
    np.testing.assert_allclose(corr(sample), corr(model), atol=0.06)
    # The velocity-random-walk term is a visible part of Cov(𝒵) here (otherwise the test could not fail on A₁, A₂).
    share = np.diag(cfg.S_v * pf.D[0] + cfg.S_v * pf.D[1]) / np.diag(model)
    assert share.max() > 0.3
    # The per-axis model of the stacked module agrees with the full-matrix one.
    iv = paper_interval(cfg.T, cfg.tau, cfg.sigma_ss)
    per_axis = cov_z_model(
        iv.Phi, np.array([[1.0, 0, 0], [0, 1.0, 0]]), Qa1=iv.Qa1, qb=iv.qb, R=np.diag(cfg.R_diag[:2]),
        S_v=cfg.S_v, bias_index=2,
    )
    scale = np.sqrt(np.outer(np.diag(per_axis), np.diag(per_axis)))
    assert np.max(np.abs(model[:3, :3] - per_axis) / scale) < 1e-8


def test_batched_axis_filter_equals_paper_filter():
    cfg = TurntableConfig()
    run = simulate_turntable(cfg, 300.0, np.random.default_rng(1))
    pf = _paper_filter(cfg, run.z[0])
    af = AxisCmkf(2, cfg.S_v0, pd_check="joint")
    af.initialise(pf.x.reshape(2, 3), np.stack([pf.P[:3, :3], pf.P[3:, 3:]]))
    iv = paper_interval(cfg.T, cfg.tau, cfg.sigma_ss)
    Rax = np.broadcast_to(np.diag(cfg.R_diag[:2]), (2, 2, 2))
    for k in range(len(run.dv)):
        pf.predict(run.dv[k])
        af.predict(af.x @ iv.Phi.T + run.dv[k][:, None] * np.array([cfg.T / 2, 1.0, 0.0]), iv)
        pf.update(run.z[k + 1])
        af.update(run.z[k + 1].reshape(2, 2), Rax)
    np.testing.assert_allclose(af.x, pf.x.reshape(2, 3), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(af.S_used, pf.S_used, rtol=1e-9)
    np.testing.assert_allclose(af.S_ls, pf.S_ls, rtol=1e-9)


def test_planar_robot_filter_equals_paper_filter():
    """No rotation, identity mounting, gravity on z, one IMU sample per odometry epoch: the robot filter's x and y
    axes are paper 004's filter (state, covariance, S_v estimate), up to the position anchor (the paper has no
    innovation gate: off here, with min_samples = 1 the first S_v estimates are wild and the gate would act; and
    the paper keeps the last positive S_v: pd_check per_axis)."""
    cfg = TurntableConfig()
    run = simulate_turntable(cfg, 200.0, np.random.default_rng(5))
    pf = _paper_filter(cfg, run.z[0], pd_check="per_axis")
    rc = RobotCmkf(CmkfConfig(
        measurement="pose_twist", accel_bias_tau=cfg.tau, accel_bias_sigma=cfg.sigma_ss, s_v0=cfg.S_v0,
        min_samples=1, nis_gate_probability=0.0, pd_check="per_axis", position_noise_std=math.sqrt(cfg.R_diag[0]),
        velocity_noise_std=math.sqrt(cfg.R_diag[1]),
    ))

    def odometry(k: int) -> None:
        z = run.z[k]
        rc.process_odometry(run.t[k], position=[z[0], z[2], 0.0], orientation_xyzw=[0, 0, 0, 1],
                            linear_velocity=[z[1], z[3], 0.0], angular_velocity=[0.0, 0.0, 0.0])

    rc.process_imu(-cfg.T, [0, 0, 0], [0, 0, G])
    odometry(0)
    for k in range(len(run.dv)):
        pf.predict(run.dv[k])
        rc.process_imu(run.t[k + 1], [0.0, 0.0, 0.0], [run.dv[k, 0] / cfg.T, run.dv[k, 1] / cfg.T, G])
        pf.update(run.z[k + 1])
        odometry(k + 1)
    x = rc.filter.x[:2].copy()
    x[:, 0] += run.z[0, [0, 2]]  # the robot filter measures position from the first odometry position
    np.testing.assert_allclose(x, pf.x.reshape(2, 3), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(rc.filter.P[0], pf.P[:3, :3], rtol=1e-7, atol=1e-20)
    np.testing.assert_allclose(rc.filter.P[1], pf.P[3:, 3:], rtol=1e-7, atol=1e-20)
    np.testing.assert_allclose(rc.estimate().S_v[:2], pf.S_used, rtol=1e-7)
    assert rc.estimate().n_stacked == pf.count


def test_turntable_converges_to_S_v():
    """Short turntable Monte Carlo (6 runs, 15 min) with a noisier accelerometer (S_v = 1e-4, the paper's R):
    the median Ŝ_v over the 12 axis filters is within 15 % of the truth and every one within a factor 2
    (the paper's S_v = 1e-6 converges much more slowly: see bench/bench_cmkf_paper.py)."""
    cfg = TurntableConfig(S_v=1e-4, S_v0=2e-4)
    mc = turntable_monte_carlo(cfg, 900.0, 6, np.random.default_rng(3), record_every=100)
    final = mc.S_v[:, -1].ravel() / cfg.S_v
    assert abs(np.median(final) - 1.0) < 0.15
    assert np.all((final > 0.5) & (final < 2.0))
    # and the state is consistent once Ŝ_v has converged: average NEES of 6 dof within 20 %
    assert 4.8 < mc.nees[:, mc.t > 450].mean() < 7.2


@pytest.fixture(scope="module")
def robot_run():
    return simulate_robot(300.0, np.random.default_rng(7))


def test_robot_recovers_biases_and_S_v(robot_run):
    """Moving robot (turning, accelerating), IMU rotated (y up), IMU 100 Hz, odometry twist 10 Hz."""
    run = robot_run
    f = RobotCmkf(CmkfConfig(imu_rotation_xyzw=run.imu_rotation_xyzw, s_v0=2e-4))
    est = replay_arrays(f, run)
    e = est[-1]
    assert e.status == "tracking" and e.observed
    # biases within 3σ of the filter's own uncertainty (σ ≈ 5e-3 m/s² after 300 s with τ = 3600 s, σ_ss = 0.1)
    assert np.all(np.abs(e.accel_bias - run.accel_bias) < 3 * e.accel_bias_std)
    assert np.all(e.accel_bias_std < 0.01)
    # S_v = 1e-4 from ~3000 stacked samples: within 25 % (observed spread over seeds ~10 %)
    np.testing.assert_allclose(e.S_v, 1e-4, rtol=0.25)
    np.testing.assert_allclose(e.accel_noise_density, np.sqrt(e.S_v))
    # consistency: mean NIS over the last 2000 updates close to its 3 dof
    nis = np.array([x.nis_accel for x in est[1000:]])
    assert 2.7 < nis.mean() < 3.3
    # gyro biases within 3σ, gyro NIS consistent
    assert np.all(np.abs(e.gyro_bias - run.gyro_bias) < 3 * e.gyro_bias_std)
    assert 2.5 < np.mean([x.nis_gyro for x in est[1000:]]) < 3.6


def test_robot_pose_twist_mode_runs(robot_run):
    """Position + velocity (paper's eq. 8) on the same robot (≈ 180 m driven): biases recovered and the position
    innovations consistent (the displacement is accumulated in the odometry frame, so gyro errors do not multiply
    the distance travelled)."""
    run = robot_run
    f = RobotCmkf(CmkfConfig(imu_rotation_xyzw=run.imu_rotation_xyzw, measurement="pose_twist", s_v0=2e-4))
    est = replay_arrays(f, run)
    e = est[-1]
    assert e.nis_accel_dof == 6
    assert np.all(np.abs(e.accel_bias - run.accel_bias) < 3 * e.accel_bias_std)
    np.testing.assert_allclose(e.S_v, 1e-4, rtol=0.25)
    assert 5.4 < np.mean([x.nis_accel for x in est[1000:]]) < 6.6


def _short_run() -> object:
    return simulate_robot(40.0, np.random.default_rng(2))


def _feed(f: RobotCmkf | CmkfStream, run, imu_idx=None, odom_idx=None) -> None:
    imu_idx = range(len(run.imu_t)) if imu_idx is None else imu_idx
    odom_idx = range(len(run.odom_t)) if odom_idx is None else odom_idx
    events = [(run.imu_t[i], 0, i) for i in imu_idx] + [(run.odom_t[j], 1, j) for j in odom_idx]
    for _, kind, i in sorted(events):
        if kind == 0:
            f.process_imu(run.imu_t[i], run.gyro[i], run.accel[i])
        else:
            f.process_odometry(run.odom_t[i], orientation_xyzw=run.orientation_xyzw[i],
                               linear_velocity=run.linear_velocity[i], angular_velocity=run.angular_velocity[i],
                               twist_cov=run.twist_cov[i])


def test_odometry_gap_restarts_the_stacked_chain():
    run = _short_run()
    f = RobotCmkf(CmkfConfig(imu_rotation_xyzw=run.imu_rotation_xyzw))
    keep = [j for j in range(len(run.odom_t)) if not (15.0 < run.odom_t[j] < 18.0)]
    _feed(f, run, odom_idx=keep)
    e = f.estimate()
    assert e.counters["odom_gaps"] == 1
    # one chain restart costs the two epochs needed to refill the 3-epoch window
    assert e.n_stacked == e.counters["updates"] - 2 - 2
    assert e.status in ("converging", "tracking")
    assert np.all(np.abs(e.accel_bias - run.accel_bias) < 3 * e.accel_bias_std)


def test_out_of_order_duplicate_and_nan_messages_are_dropped():
    run = _short_run()
    f = RobotCmkf(CmkfConfig(imu_rotation_xyzw=run.imu_rotation_xyzw))
    _feed(f, run, imu_idx=range(1000), odom_idx=range(100))
    before = f.estimate()
    assert not f.process_imu(run.imu_t[999], run.gyro[999], run.accel[999])  # duplicate stamp
    assert not f.process_imu(run.imu_t[500], run.gyro[500], run.accel[500])  # out of order
    assert not f.process_imu(run.imu_t[999] + 0.005, [np.nan, 0, 0], run.accel[999])
    assert not f.process_odometry(run.odom_t[99], orientation_xyzw=run.orientation_xyzw[99],
                                  linear_velocity=run.linear_velocity[99])
    assert not f.process_odometry(run.odom_t[99] + 0.01, orientation_xyzw=run.orientation_xyzw[99],
                                  linear_velocity=[np.inf, 0, 0])
    after = f.estimate()
    c = after.counters
    dropped = (c["imu_dropped_stamp"], c["imu_dropped_nan"], c["odom_dropped_stamp"], c["odom_dropped_nan"])
    assert dropped == (2, 1, 1, 1)
    np.testing.assert_array_equal(before.accel_bias, after.accel_bias)
    # the stream continues normally afterwards
    _feed(f, run, imu_idx=range(1000, len(run.imu_t)), odom_idx=range(100, len(run.odom_t)))
    assert f.estimate().counters["updates"] > 300


def test_odometry_only_estimates_nothing():
    run = _short_run()
    f = RobotCmkf(CmkfConfig())
    _feed(f, run, imu_idx=[])
    e = f.estimate()
    assert e.status == "no_imu" and not e.observed
    assert e.counters["odom_without_imu"] == len(run.odom_t) and e.counters["updates"] == 0
    assert RobotCmkf().estimate().status == "no_data"


def test_imu_only_propagates_with_growing_covariance():
    run = _short_run()
    f = RobotCmkf(CmkfConfig(imu_rotation_xyzw=run.imu_rotation_xyzw))
    _feed(f, run, imu_idx=range(100), odom_idx=[])
    e = f.estimate()
    assert e.status == "imu_only" and not e.observed
    np.testing.assert_array_equal(e.accel_bias_std, 0.1)  # the prior: nothing observed
    # odometry stops after 10 s, IMU continues: unobserved, covariance grows
    first_10s = [j for j in range(len(run.odom_t)) if run.odom_t[j] <= 10]
    _feed(f, run, imu_idx=range(100, len(run.imu_t)), odom_idx=first_10s)
    e = f.estimate()
    assert e.status == "unobserved" and not e.observed
    P_late = f.filter.predicted_P(f.imu.interval())
    assert np.all(P_late[:, 1, 1] > 10 * f.filter.P[:, 1, 1])
    assert np.all(e.accel_bias_std > np.sqrt(f.filter.P[:, 2, 2]))


def test_bad_configuration_is_rejected():
    with pytest.raises(ValueError, match="measurement"):
        RobotCmkf(CmkfConfig(measurement="gps"))
    with pytest.raises(ValueError, match="s_v0"):
        RobotCmkf(CmkfConfig(s_v0=-1.0))
    with pytest.raises(ValueError, match="quaternion"):
        RobotCmkf(CmkfConfig(imu_rotation_xyzw=(0, 0, 0, 0)))
    with pytest.raises(ValueError, match="initial S_v"):
        AxisCmkf(2, 0.0)


def test_cli_cmkf_on_husky_bag(shared_data, tmp_path):
    """The replay CLI on the Husky bag (IMU rotated: gravity on +y) writes the cmkf.yaml schema."""
    import yaml

    from imu_noise_id.cli import main

    bag = shared_data / "husky_robot_localization" / "husky_test1_ros2"
    out = tmp_path / "out"
    assert main(["cmkf", str(bag), "--imu-rotation", "-1.570796327", "0", "1.570796327", "--out", str(out),
                 "--no-plot"]) == 0
    data = yaml.safe_load((out / "cmkf.yaml").read_text())
    for key in ("accel_bias", "accel_bias_std", "S_v", "accel_noise_density", "gyro_bias", "gyro_bias_std"):
        assert set(data[key]) == {"x", "y", "z"}
    # every odometry message but the first updates the filter or is rejected by the innovation gate (slip)
    assert data["counters"]["imu"] == 11865
    assert data["counters"]["updates"] + data["counters"]["gated_accel"] > 3900
    assert data["counters"]["gated_accel"] < 0.03 * 3952
    assert data["status"] == "tracking"
    lines = (out / "cmkf.csv").read_text().splitlines()
    assert lines[0].startswith("# imu-noise-id run: ")  # the run that wrote it
    assert len(lines) == 1 + 3952 + 1
    # gravity removed correctly: the estimated accel biases are small compared with g
    assert max(abs(v) for v in data["accel_bias"].values()) < 0.5


def test_cli_cmkf_bad_rotation_exits_2(shared_data, tmp_path, capsys):
    from imu_noise_id.cli import main

    bag = shared_data / "husky_robot_localization" / "husky_test1_ros2"
    assert main(["cmkf", str(bag), "--imu-rotation", "1", "2", "--out", str(tmp_path)]) == 2
    assert "--imu-rotation" in capsys.readouterr().err


def test_plain_float_velocity_filter_equals_batched_filter(robot_run):
    """The robot's twist path (VelocityAxisCmkf, plain floats) is AxisCmkf(mode="vel") written out."""
    from imu_noise_id.core.cmkf.fast_vel import VelocityAxisCmkf
    from imu_noise_id.core.cmkf.interval import ImuInterval

    rng = np.random.default_rng(4)
    fast = VelocityAxisCmkf(3, 2e-4, pd_check="per_axis", min_samples=1)
    ref = AxisCmkf(3, 2e-4, mode="vel", pd_check="per_axis", min_samples=1)
    v0, b0 = rng.normal(size=3), rng.normal(size=3) * 0.01
    x0, P0 = np.column_stack([np.zeros(3), v0, b0]), np.stack([np.diag([1.0, 1e-4, 1e-2])] * 3)
    fast.initialise(x0, P0)
    ref.initialise(x0, P0)
    for k in range(400):
        T = 0.1 + 0.02 * rng.random()  # jittery odometry intervals
        Bv, beta = T * (1 - 1e-5), np.exp(-T / 3600)
        qb = (1 - beta**2) * 0.01
        interval = ImuInterval(T, T * T / 2, Bv, beta, T**3 / 3, T * T / 2, qb)
        x_pred = ref.x @ interval.Phi.T + rng.normal(size=(3, 3)) * 0.01
        ref.predict(x_pred, interval)
        fast.predict(x_pred, interval)
        z = rng.normal(size=3) * 0.01 + x_pred[:, 1]
        R = 1e-4 * (1 + rng.random(3))
        gap = k == 200
        nis_ref = ref.update(z[:, None], R[:, None, None], new_chain=gap)
        nis_fast = fast.update(z[:, None], R[:, None, None], new_chain=gap)
        assert nis_fast.sum() == pytest.approx(nis_ref.sum(), rel=1e-9)
    np.testing.assert_allclose(fast.x[:, 1], ref.x[:, 1], rtol=1e-9)
    np.testing.assert_allclose(fast.x[:, 2], ref.x[:, 2], rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(fast.P[:, 1:, 1:], ref.P[:, 1:, 1:], rtol=1e-8)
    np.testing.assert_allclose(fast.S_ls, ref.estimator.estimate, rtol=1e-8)
    np.testing.assert_allclose(fast.S_used, ref.S_used, rtol=1e-8)
    assert fast.count == ref.estimator.count == 400 - 2 - 2


def test_late_odometry_and_imu_gap():
    run = _short_run()
    f = CmkfStream(CmkfConfig(imu_rotation_xyzw=run.imu_rotation_xyzw))
    _feed(f, run, imu_idx=range(1000), odom_idx=range(99))  # IMU to 10.0 s, odometry to 9.9 s
    # odometry 10.0 s arrives after the IMU sample at 10.0 s (equal stamp: normal); one at 9.98 s is late
    j = 99
    f.process_odometry(run.odom_t[j] - 0.02, orientation_xyzw=run.orientation_xyzw[j],
                       linear_velocity=run.linear_velocity[j], angular_velocity=run.angular_velocity[j])
    assert f.flush()  # applied at its own stamp, between the IMU samples
    assert f.estimate().counters["odom_late"] == 1
    # the IMU stops for 2 s (> max_imu_gap): position/velocity re-initialised at the next odometry, bias kept
    bias_before = f.estimate().accel_bias.copy()
    _feed(f, run, imu_idx=[i for i in range(1000, len(run.imu_t)) if run.imu_t[i] <= 12.0],
          odom_idx=[j for j in range(100, len(run.odom_t)) if run.odom_t[j] <= 13.0])
    assert f.estimate().status == "unobserved"  # odometry goes on, the IMU stopped
    _feed(f, run, imu_idx=[i for i in range(len(run.imu_t)) if run.imu_t[i] >= 14.0],
          odom_idx=[j for j in range(len(run.odom_t)) if run.odom_t[j] > 13.0])
    e = f.estimate()
    assert e.counters["imu_gaps"] >= 1
    assert e.status == "tracking", (e.consistency_reason, e.accel_psd, e.S_v, e.S_g)
    assert np.all(np.abs(e.accel_bias - bias_before) < 3 * e.accel_bias_std)
    assert np.all(np.abs(e.accel_bias - run.accel_bias) < 3 * e.accel_bias_std)


def test_gravity_from_imu_orientation_equals_odometry_orientation_on_flat_ground():
    """On flat ground the odometry's yaw-only orientation is the full orientation: gravity from the IMU's own
    orientation (passed with every IMU sample) gives the same estimates up to the gyro-propagation error."""
    from imu_noise_id.core.cmkf import rotation as rot

    run = _short_run()
    psi = np.interp(run.imu_t, run.odom_t, np.unwrap(2 * np.arctan2(run.orientation_xyzw[:, 2],
                                                                     run.orientation_xyzw[:, 3])))
    q_imu = [rot.multiply((0.0, 0.0, np.sin(p / 2), np.cos(p / 2)), run.imu_rotation_xyzw) for p in psi]
    ests = {}
    for source in ("odometry", "imu"):
        f = RobotCmkf(CmkfConfig(imu_rotation_xyzw=run.imu_rotation_xyzw, gravity_source=source))
        events = sorted([(t, 0, i) for i, t in enumerate(run.imu_t)] + [(t, 1, j) for j, t in enumerate(run.odom_t)])
        for _, kind, i in events:
            if kind == 0:
                f.process_imu(run.imu_t[i], run.gyro[i], run.accel[i], orientation_xyzw=q_imu[i])
            else:
                f.process_odometry(run.odom_t[i], orientation_xyzw=run.orientation_xyzw[i],
                                   linear_velocity=run.linear_velocity[i], angular_velocity=run.angular_velocity[i],
                                   twist_cov=run.twist_cov[i])
        ests[source] = f.estimate()
    np.testing.assert_allclose(ests["imu"].accel_bias, ests["odometry"].accel_bias, atol=2e-3)
    assert ests["imu"].status == ests["odometry"].status == "tracking"


def test_malformed_odometry_is_dropped_not_raised():
    run = _short_run()
    f = RobotCmkf(CmkfConfig(imu_rotation_xyzw=run.imu_rotation_xyzw))
    _feed(f, run, imu_idx=range(100), odom_idx=range(10))
    # gravity from the odometry needs its orientation: an all-zero quaternion drops the message
    assert not f.process_odometry(1.05, orientation_xyzw=[0, 0, 0, 0], linear_velocity=[0.5, 0, 0])
    assert not f.process_odometry(1.06, orientation_xyzw=[0, 0, 0, 1], linear_velocity=[0.5, 0])
    assert f.estimate().counters["odom_dropped_nan"] == 1
    assert f.estimate().counters["odom_dropped_orientation"] == 1
    assert not f.process_imu(1.055, [0.0, 0.0], [0.0, 0.0, 9.8])
    assert f.estimate().counters["imu_dropped_nan"] == 1
    # a covariance of the wrong size counts as unknown (default noise), not as an error
    assert f.process_odometry(1.07, orientation_xyzw=[0, 0, 0, 1], linear_velocity=[0.5, 0, 0],
                              twist_cov=np.eye(3))


def test_cli_cmkf_bag_without_odometry_exits_2(tmp_path, capsys):
    from imu_noise_id.cli import main

    bag = tmp_path / "imu_only"
    assert main(["simulate", "--model", "WN(1e-3)", "--rate", "100", "--duration", "2", "--out", str(bag),
                 "--seed", "1"]) == 0
    capsys.readouterr()
    assert main(["cmkf", str(bag), "--out", str(tmp_path / "out")]) == 2
    assert "Odometry" in capsys.readouterr().err
    assert main(["cmkf", str(bag), "--s-v0", "-1", "--out", str(tmp_path / "out")]) == 2
    assert "s_v0" in capsys.readouterr().err


def _odom_kwargs(run, j: int) -> dict:
    return dict(position=run.position[j], orientation_xyzw=run.orientation_xyzw[j],
                linear_velocity=run.linear_velocity[j], angular_velocity=run.angular_velocity[j],
                pose_cov=run.pose_cov[j], twist_cov=run.twist_cov[j])


@pytest.mark.parametrize("measurement", ["twist", "pose_twist"])
def test_late_duplicated_and_zero_interval_odometry_never_raises(measurement):
    """Odometry stamped behind the IMU-propagated state (two late messages per epoch, the second one with no IMU
    sample in between: a zero-length interval before the fix), duplicated stamps, and odometry repeated at the
    stamp of the last update: the filter must neither raise (it raised LinAlgError / ZeroDivisionError) nor
    produce non-finite estimates, and must count what it dropped."""
    run = simulate_robot(10.0, np.random.default_rng(2))
    f = CmkfStream(CmkfConfig(imu_rotation_xyzw=run.imu_rotation_xyzw, measurement=measurement))
    for i in range(len(run.imu_t)):
        f.process_imu(run.imu_t[i], run.gyro[i], run.accel[i])
        if i % 10 == 9:
            j = i // 10
            for lag in (0.025, 0.015, 0.015, 0.5):  # late, late again, duplicate, beyond the tolerance
                f.process_odometry(run.odom_t[j] - lag, **_odom_kwargs(run, j))
            f.process_odometry(run.odom_t[j] - 0.015 + 1e-9, **_odom_kwargs(run, j))  # 1 ns after the last update
    f.flush()
    e = f.estimate()
    c = e.counters
    assert c["updates"] > 150
    assert c["odom_dropped_stamp"] >= 99 and c["odom_dropped_interval"] >= 99
    for name in ("accel_bias", "accel_bias_std", "S_v", "gyro_bias", "gyro_bias_std", "S_g"):
        assert np.all(np.isfinite(getattr(e, name))), name
    assert np.all(np.abs(e.accel_bias - run.accel_bias) < 4 * e.accel_bias_std)


@pytest.mark.parametrize("measurement", ["twist", "pose_twist"])
def test_late_odometry_within_tolerance_equals_in_order_processing(measurement):
    """Odometry arriving up to 30 ms after IMU samples with later stamps is applied at its own stamp (the stamp
    merger holds the IMU samples late_odom_tolerance behind): the result equals processing the stream in order."""
    run = simulate_robot(20.0, np.random.default_rng(4))
    cfg = CmkfConfig(imu_rotation_xyzw=run.imu_rotation_xyzw, measurement=measurement)
    in_order, late = RobotCmkf(cfg), CmkfStream(cfg)
    odom_t = run.odom_t + 0.0037  # between IMU samples
    for f, delay in ((in_order, 0.0), (late, 0.03)):
        events = sorted([(t, 0, i) for i, t in enumerate(run.imu_t)]
                        + [(t + delay, 1, j) for j, t in enumerate(odom_t)])
        for _, kind, i in events:
            if kind == 0:
                f.process_imu(run.imu_t[i], run.gyro[i], run.accel[i])
            else:
                f.process_odometry(odom_t[i], **_odom_kwargs(run, i))
    late.flush()
    a, b = in_order.estimate(), late.estimate()
    assert b.counters["odom_late"] == len(run.odom_t) - 1  # all but the last (no IMU sample after it)
    assert a.counters["updates"] == b.counters["updates"] == len(run.odom_t) - 1
    for name in ("accel_bias", "accel_bias_std", "S_v", "gyro_bias", "S_g"):
        np.testing.assert_allclose(getattr(b, name), getattr(a, name), rtol=1e-12, atol=1e-15, err_msg=name)
    assert b.nis_accel_mean == pytest.approx(a.nis_accel_mean, rel=1e-12)


def test_degenerate_intervals_in_the_estimators_are_skipped():
    """The building blocks skip (and count) an update or stacked step they cannot compute instead of raising:
    zero innovation variance (zero covariance, zero interval) and zero-length intervals (M_o singular)."""
    from imu_noise_id.core.cmkf.fast_vel import VelocityAxisCmkf
    from imu_noise_id.core.cmkf.interval import ImuInterval

    fast = VelocityAxisCmkf(3, 1e-4)
    ref = AxisCmkf(3, 1e-4, mode="pos_vel")
    fast.initialise(np.zeros((3, 3)), np.stack([np.diag([0.0, 0.0, 1e-2])] * 3))
    ref.initialise(np.zeros((3, 3)), np.stack([np.diag([0.0, 0.0, 1e-2])] * 3))
    zero = ImuInterval(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)
    for _ in range(4):  # zero covariance, zero interval, R = 0: s = 0
        fast.predict(np.zeros((3, 3)), zero)
        assert np.all(np.isnan(fast.update(np.zeros((3, 1)), np.zeros((3, 1, 1)))))
        ref.predict(np.zeros((3, 3)), zero)
        assert np.all(np.isnan(ref.update(np.zeros((3, 2)), np.zeros((3, 2, 2)))))
    assert fast.skipped == 4 and ref.skipped == 4
    for _ in range(4):  # R > 0: the update works, the stacked step over a zero-length interval does not
        fast.predict(fast.x, zero)
        assert np.all(np.isfinite(fast.update(np.zeros((3, 1)), np.full((3, 1, 1), 1e-4))))
        ref.predict(ref.x, zero)
        assert np.all(np.isfinite(ref.update(np.zeros((3, 2)), np.stack([np.eye(2) * 1e-4] * 3))))
    assert fast.skipped == 4 and ref.skipped == 4
    assert fast.skipped_stacked == 4 and ref.skipped_stacked == 4
    assert fast.count == ref.estimator.count == 0


def test_cli_cmkf_gravity_from_imu_orientation_beats_planar_odometry_on_husky(shared_data, tmp_path, capsys):
    """The Husky's IMU provides its orientation: the CLI uses it by default, and on the uneven ground the filter
    fits better than with gravity from the planar wheel odometry's orientation: a lower NIS and fewer updates
    rejected by the innovation gate (docs/cmkf.md, "Measured data")."""
    import yaml

    from imu_noise_id.cli import main

    bag = shared_data / "husky_robot_localization" / "husky_test1_ros2"
    nis, gated = {}, {}
    for choice in (None, "imu", "odom"):
        out = tmp_path / str(choice)
        extra = [] if choice is None else ["--gravity-from", choice]
        assert main(["cmkf", str(bag), "--imu-rotation", "-1.570796327", "0", "1.570796327", "--out", str(out),
                     "--no-plot", *extra]) == 0
        data = yaml.safe_load((out / "cmkf.yaml").read_text())
        nis[choice], gated[choice] = data["nis"]["accel"]["mean"], data["nis"]["accel"]["gated"]
        assert data["filter"]["parameters"]["gravity_source"] == ("odometry" if choice == "odom" else "imu")
    assert nis[None] == nis["imu"]
    assert nis["imu"] < 0.9 * nis["odom"] and gated["imu"] < gated["odom"]
    assert "gravity from the IMU orientation" in capsys.readouterr().out


def test_cli_cmkf_gravity_from_imu_without_orientation_exits_2(tmp_path, capsys):
    from imu_noise_id.bag.writer import write_bag
    from imu_noise_id.cli import main
    from imu_noise_id.core.axes import ImuSeries, OdometrySeries

    run = simulate_robot(5.0, np.random.default_rng(1))
    imu = ImuSeries(t=run.imu_t + 100.0, gyro=run.gyro, accel=run.accel)  # no orientation
    odom = OdometrySeries(t=run.odom_t + 100.0, position=run.position, orientation_xyzw=run.orientation_xyzw,
                          linear_velocity=run.linear_velocity, angular_velocity=run.angular_velocity,
                          pose_covariance=run.pose_cov, twist_covariance=run.twist_cov)
    write_bag(tmp_path / "bag", imu, odom)
    assert main(["cmkf", str(tmp_path / "bag"), "--gravity-from", "imu", "--out", str(tmp_path / "out")]) == 2
    assert "--gravity-from odom" in capsys.readouterr().err
    assert main(["cmkf", str(tmp_path / "bag"), "--out", str(tmp_path / "out"), "--no-plot"]) == 0  # default: odom
    assert "gravity from the odometry orientation" in capsys.readouterr().out


def test_one_robot_simulator_with_two_motion_profiles():
    """simulate_robot with the Weaving (default) and StopAndGo profiles: standing means zero odometry speed and an
    IMU reading of gravity plus the biases; the optional bias random walk drifts the IMU, the rest stays."""
    from imu_noise_id.core.cmkf import rotation as rot
    from imu_noise_id.core.simulation.robot import RobotSensors, StopAndGo

    sensors = RobotSensors(imu_rotation_xyzw=rot.IDENTITY, S_v=1e-8, S_g=1e-10, noise_order=("gyro", "accel"))
    run = simulate_robot(12.0, np.random.default_rng(0), motion=StopAndGo(stand_before=4.0, drive=4.0),
                         sensors=sensors, t0=50.0)
    assert run.imu_t[0] == pytest.approx(50.01) and run.odom_t[-1] == pytest.approx(62.0)
    standing = (run.odom_t - 50.0 < 4.0) | (run.odom_t - 50.0 > 8.0)
    assert np.all(np.abs(run.linear_velocity[standing, 0]) < 0.01)
    assert np.max(run.linear_velocity[~standing, 0]) > 0.9
    still = run.imu_t - 50.0 < 3.9
    np.testing.assert_allclose(run.accel[still].mean(axis=0), np.array([0, 0, G]) + sensors.accel_bias, atol=1e-3)
    np.testing.assert_allclose(run.gyro[still].mean(axis=0), sensors.gyro_bias, atol=1e-4)
    weaving = simulate_robot(12.0, np.random.default_rng(0))
    assert np.all(weaving.linear_velocity[:, 0] > 0.1)  # always moving
    drifting = simulate_robot(12.0, np.random.default_rng(0), motion=StopAndGo(stand_before=4.0, drive=4.0),
                              sensors=RobotSensors(imu_rotation_xyzw=rot.IDENTITY, S_v=1e-8, S_g=1e-10,
                                                   noise_order=("gyro", "accel"), accel_random_walk=0.05),
                              t0=50.0)
    np.testing.assert_array_equal(drifting.gyro, run.gyro)  # the white noise is drawn before the random walk
    assert np.max(np.abs(drifting.accel - run.accel)) > 0.01
    with pytest.raises(ValueError, match="noise_order"):
        simulate_robot(1.0, np.random.default_rng(0), sensors=RobotSensors(noise_order=("gyro", "gyro")))


def _searchsorted_order(ti: np.ndarray, to: np.ndarray) -> list[tuple[bool, int]]:
    """The replay's order before the stamp merger: the IMU samples up to each odometry stamp, then that message."""
    cut = np.searchsorted(ti, to, side="right")
    order, i = [], 0
    for j in range(to.size + 1):
        stop = int(cut[j]) if j < to.size else ti.size
        order += [(False, k) for k in range(i, stop)]
        i = max(i, stop)
        if j < to.size:
            order.append((True, j))
    return order


def test_stamp_merge_equals_the_searchsorted_order():
    """Recorded streams: stamp_order is the order the replay had (IMU first on equal stamps), also with odometry
    before or after all the IMU samples and with either stream empty."""
    from imu_noise_id.core.cmkf.merge import stamp_order

    rng = np.random.default_rng(21)
    for _ in range(20):
        ti = np.cumsum(rng.choice([0.01, 0.02], size=rng.integers(0, 60)))
        to = np.round(np.sort(rng.uniform(-0.1, 0.7, size=rng.integers(0, 20))), 2)  # ties with IMU stamps
        assert list(stamp_order(ti, to)) == _searchsorted_order(ti, to)


def test_live_merge_restores_stamp_order_within_its_latency():
    """Odometry delivered up to 40 ms after IMU samples stamped later: released in the recorded order, counted
    LATE where it was put back; 80 ms late with a 50 ms allowance: TOO_LATE."""
    from imu_noise_id.core.cmkf.merge import LATE, TOO_LATE, StampMerger

    rng = np.random.default_rng(22)
    ti = np.arange(1, 401) * 0.005
    to = np.arange(1, 41) * 0.05 + 0.0013
    for delay, allowance in ((0.04 * rng.random(to.size), 0.05), (np.full(to.size, 0.08), 0.05)):
        arrival = sorted([(t, 0, i) for i, t in enumerate(ti)] + [(t + d, 1, j) for j, (t, d) in
                                                                  enumerate(zip(to, delay, strict=True))])
        merger = StampMerger(allowance)
        released, newest_imu, expected_late = [], -1.0, 0
        for _, kind, k in arrival:
            if kind:
                expected_late += newest_imu > to[k]
                merger.push_odometry(to[k], k)
            else:
                newest_imu = ti[k]
                merger.push_imu(ti[k], k)
            released += list(merger.ready())
        released += list(merger.flush())
        orders = [order for _, is_odometry, _, order in released if is_odometry]
        if allowance > delay.max():
            assert [(o, k) for _, o, k, _ in released] == _searchsorted_order(ti, to)
            assert merger.late == orders.count(LATE) == expected_late > 0 and merger.too_late == 0
        else:
            assert merger.too_late == orders.count(TOO_LATE) >= to.size - 2  # the last ones wait in the queue
    assert merger.pending == 0


def test_the_fast_and_the_exact_filter_are_interchangeable_in_the_robot_filter():
    """RobotCmkf (twist) with its default VelocityAxisCmkf and with AxisCmkf(mode="vel") given instead: the same
    estimates at every odometry message (one CmkfFilter interface, no branch on the filter type)."""
    from imu_noise_id.core.cmkf.fast_vel import VelocityAxisCmkf

    run = simulate_robot(30.0, np.random.default_rng(8))
    cfg = CmkfConfig(imu_rotation_xyzw=run.imu_rotation_xyzw, s_v0=2e-4)
    fast, exact = RobotCmkf(cfg), RobotCmkf(cfg, AxisCmkf(3, cfg.s_v0, mode="vel", min_samples=cfg.min_samples,
                                                            pd_check=cfg.pd_check))
    assert isinstance(fast.filter, VelocityAxisCmkf)
    a, b = replay_arrays(fast, run), replay_arrays(exact, run)
    assert a[-1].status == "tracking" and a[-1].n_stacked > 250
    for ea, eb in zip(a, b, strict=True):
        for name in ("accel_bias", "accel_bias_std", "S_v", "gyro_bias", "gyro_bias_std", "S_g"):
            np.testing.assert_allclose(getattr(ea, name), getattr(eb, name), rtol=1e-8, atol=1e-14, err_msg=name)
        assert ea.nis_accel == pytest.approx(eb.nis_accel, rel=1e-8, nan_ok=True)
        assert (ea.status, ea.n_stacked, ea.counters) == (eb.status, eb.n_stacked, eb.counters)
    np.testing.assert_allclose(fast.filter.y, exact.filter.y, rtol=1e-8, atol=1e-14)
    np.testing.assert_allclose(fast.filter.S, exact.filter.S, rtol=1e-8)
    with pytest.raises(ValueError, match="measurement component"):
        RobotCmkf(cfg, AxisCmkf(3, 1e-4, mode="pos_vel"))


def test_the_robot_filter_drops_odometry_fed_behind_its_state():
    """Without a stamp merger, odometry stamped behind the IMU-propagated state is dropped and counted (putting
    two topics in stamp order is CmkfStream's job)."""
    run = _short_run()
    f = RobotCmkf(CmkfConfig(imu_rotation_xyzw=run.imu_rotation_xyzw))
    _feed(f, run, imu_idx=range(1000), odom_idx=range(99))  # IMU to 10.0 s, odometry to 9.9 s
    before = f.estimate()
    assert not f.process_odometry(9.98, orientation_xyzw=run.orientation_xyzw[99],
                                  linear_velocity=run.linear_velocity[99])
    after = f.estimate()
    assert after.counters["odom_dropped_late"] == 1 and after.counters["updates"] == before.counters["updates"]
    np.testing.assert_array_equal(after.accel_bias, before.accel_bias)


def test_simulated_stamps_are_whole_nanoseconds_and_meet_where_the_rates_divide():
    """As in a bag (integer nanoseconds), an odometry stamp at an IMU stamp is that stamp: 18 % of them were one
    float ulp off, so the odometry update came before the IMU sample that ends its interval, one sample was held
    over two periods and S_v and S_g came out 4–10 % high."""
    run = simulate_robot(30.0, np.random.default_rng(0), odom_rate=20.0)
    assert set(run.odom_t.tolist()) <= set(run.imu_t.tolist())
    np.testing.assert_array_equal(np.round(run.imu_t * 1e9) / 1e9, run.imu_t)


def test_imu_samples_without_a_valid_orientation_are_kept_with_gravity_from_the_imu():
    """Gravity from the IMU's orientation, but the messages carry none (an all-zero quaternion, as drivers publish
    beside orientation_covariance[0] = −1): every sample is still used, with gravity from the propagated orientation
    as if no orientation had been passed, and the invalid ones are counted (they were dropped as non-finite)."""
    run = _short_run()
    ests = {}
    for given in ((0.0, 0.0, 0.0, 0.0), None):
        f = RobotCmkf(CmkfConfig(imu_rotation_xyzw=run.imu_rotation_xyzw, gravity_source="imu"))
        events = sorted([(t, 0, i) for i, t in enumerate(run.imu_t)] + [(t, 1, j) for j, t in enumerate(run.odom_t)])
        for _, kind, i in events:
            if kind == 0:
                assert f.process_imu(run.imu_t[i], run.gyro[i], run.accel[i], orientation_xyzw=given)
            else:
                f.process_odometry(run.odom_t[i], orientation_xyzw=run.orientation_xyzw[i],
                                   linear_velocity=run.linear_velocity[i], angular_velocity=run.angular_velocity[i],
                                   twist_cov=run.twist_cov[i])
        ests[given is None] = f.estimate()
    invalid, absent = ests[False], ests[True]
    assert invalid.counters["imu"] == absent.counters["imu"] == len(run.imu_t)
    assert invalid.counters["imu_orientation_invalid"] == len(run.imu_t) and invalid.counters["imu_dropped_nan"] == 0
    np.testing.assert_array_equal(invalid.accel_bias, absent.accel_bias)
    assert invalid.status == "tracking"
