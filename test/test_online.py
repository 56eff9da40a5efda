"""The node's ROS-free logic (imu_noise_id.pipelines.online), the monitor view and the play loader, without DDS."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from imu_noise_id.core.errors import InputError
from imu_noise_id.core.white_noise import FirstDifferences
from imu_noise_id.demo.online import simulate_demo_run
from imu_noise_id.pipelines.online import ERROR, OK, STALE, WARN, OnlineIdentifier
from imu_noise_id.pipelines.online.config import PARAMETERS, OnlineConfig
from imu_noise_id.pipelines.online.stamps import StampChecker
from imu_noise_id.pipelines.online.stationarity import StationarityDetector
from imu_noise_id.resources import read_hypotheses_file

REPO_ROOT = Path(__file__).resolve().parents[1]
GYRO_BIAS = (0.004, -0.006, 0.003)
ACCEL_BIAS = (0.08, -0.05, 0.06)


def _flatten(tree: dict, prefix: str = "") -> dict:
    out = {}
    for key, value in tree.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(_flatten(value, name + "."))
        else:
            out[name] = value
    return out


def test_yaml_defaults_match_the_declared_parameters():
    data = yaml.safe_load((REPO_ROOT / "config" / "imu_noise_id.yaml").read_text())
    values = _flatten(data["imu_noise_id_node"]["ros__parameters"])
    assert sorted(values) == sorted(p.name for p in PARAMETERS)
    for p in PARAMETERS:
        expected = list(p.default) if isinstance(p.default, tuple) else p.default
        assert values[p.name] == expected, p.name
    OnlineConfig(values)  # the shipped file is valid


def test_the_cmkf_defaults_are_written_once():
    """The node's cmkf.* and nis.window parameters and the options of imu-noise-id cmkf default to CmkfConfig."""
    import dataclasses

    from imu_noise_id.cli import build_parser
    from imu_noise_id.core.cmkf.config import CmkfConfig
    from imu_noise_id.pipelines.online.config import cmkf_config

    # the one exception: the stamp merger's allowance, 0.1 s for a ROS graph's topics (node) and 0.05 s in the core
    assert cmkf_config(OnlineConfig()) == dataclasses.replace(CmkfConfig(), late_odom_tolerance=0.1)
    args = build_parser().parse_args(["cmkf", "bag"])
    for name in ("measurement", "velocity_noise_std", "position_noise_std", "angular_velocity_noise_std",
                 "accel_bias_tau", "accel_bias_sigma", "s_v0", "gyro_bias_tau", "gyro_bias_sigma"):
        assert getattr(args, name) == getattr(CmkfConfig(), name), name


@pytest.mark.parametrize(
    ("name", "value", "fragment"),
    [
        ("stationary.window", -1.0, "outside its range"),
        ("noise.min_samples", 2.5, "integer"),
        ("stationary.require_odometry", 1, "true or false"),
        ("cmkf.measurement", "gps", "one of twist, pose_twist"),
        ("cmkf.imu_rotation_xyzw", (0.0, 1.0), "4 finite numbers"),
        ("gap_factor", math.nan, "finite"),
        ("no_such_parameter", 1.0, "unknown parameter"),
    ],
)
def test_bad_parameters_are_rejected_with_their_name(name, value, fragment):
    with pytest.raises(InputError, match=fragment) as info:
        OnlineConfig({name: value})
    assert name in str(info.value)


def test_runtime_update_rejects_start_up_only_parameters_and_keeps_the_old_config():
    config = OnlineConfig()
    assert config.updated({"stationary.enter_delay": 2}).stationary_enter_delay == 2.0
    with pytest.raises(InputError, match="cannot change at runtime"):
        config.updated({"publish_rate": 5.0})
    with pytest.raises(InputError, match="outside its range"):
        config.updated({"stationary.guard": -3.0})
    assert config.stationary_enter_delay == 1.0


def test_stamp_checker_verdicts():
    c = StampChecker(gap_factor=5.0, backward_reset_count=3)
    stamps = (0.0, math.nan, *(1.0 + 0.01 * np.arange(12)), 1.11, 1.105, 1.12, 1.5, 1.51)
    verdicts = [c.check(t)[0] for t in stamps]
    assert verdicts == ["bad_stamp", "bad_stamp", *["ok"] * 12, "duplicate", "backward", "ok", "hold", "ok"]
    assert c.counts["gap"] == 1  # 1.5 was held, and 1.51 confirmed it
    assert c.rate == pytest.approx(100.0, rel=0.01)
    # Three consecutive stamps behind the last accepted one, following one another: the source restarted.
    assert [c.check(t)[0] for t in (0.1, 0.11, 0.12, 0.13)] == ["backward", "backward", "restart", "ok"]


def _still(det: StationarityDetector, t0: float, n: int, rate: float, rng: np.random.Generator) -> list[bool]:
    out = []
    for k in range(n):
        sample = np.concatenate([rng.normal(0, 0.01, 3), rng.normal(0, 0.05, 3) + np.array([0, 0, 9.81])])
        out.append(det.update_imu(t0 + k / rate, sample, np.zeros(3)))
    return out


def test_stationarity_needs_enter_delay_and_leaves_at_the_first_motion():
    rng = np.random.default_rng(0)
    cfg = OnlineConfig({"stationary.enter_delay": 1.0, "stationary.window": 0.2})
    det = StationarityDetector(cfg)
    det.update_odometry(0.0, 0.0, 0.0)
    states = _still(det, 0.0, 300, 100.0, rng)  # 3 s still, odometry says still at t = 0 only
    assert det.odom_fresh is False  # older than odom_timeout: IMU decides alone
    first = states.index(True)
    # The IMU statistics need a few samples, then 1.0 s of "still" evidence.
    assert 1.0 <= first / 100.0 <= 1.3
    assert all(states[first:])
    det.update_odometry(3.0, 0.3, 0.0)  # the wheels turn
    assert _still(det, 3.0, 1, 100.0, rng) == [False]


def test_stationarity_with_require_odometry_never_without_odometry():
    rng = np.random.default_rng(1)
    det = StationarityDetector(OnlineConfig({"stationary.require_odometry": True}))
    assert not any(_still(det, 0.0, 400, 100.0, rng))


def test_allan_tau0_density_of_white_noise_and_its_rstd():
    rng = np.random.default_rng(2)
    dt, density = 0.005, 2e-3
    est = FirstDifferences(6)
    drift = np.cumsum(rng.normal(0, 1e-5, 20000))  # a slow random walk the differences must ignore
    for k in range(20000):
        est.add(k * dt, np.full(6, drift[k]) + rng.normal(0, density / math.sqrt(dt), 6))
    rstd = est.relative_std()
    assert rstd == pytest.approx(math.sqrt(3 / 19999) / 2)
    # Six axes within 4 relative standard deviations (a false alarm has probability < 1e-3).
    assert np.all(np.abs(est.density() / density - 1) < 4 * rstd)


def test_the_online_noise_density_is_the_batch_white_noise_estimate():
    """One τ₀ estimate: the node's streaming FirstDifferences (stamps, chains) equals the hypotheses' batch
    white_noise_estimate on the same samples, and a broken chain drops exactly the difference across the break."""
    from imu_noise_id.core.hypotheses.config import white_noise_estimate

    rng = np.random.default_rng(4)
    dt = 0.01
    y = 3.0 + rng.normal(0.0, 0.1, 500) + np.linspace(0.0, 0.5, 500)
    stream = FirstDifferences(1)
    for k, value in enumerate(y):
        stream.add(100.0 + k * dt, np.array([value]))
    assert stream.n == 499 and stream.sum_dt == pytest.approx(499 * dt)
    assert stream.density()[0] == pytest.approx(white_noise_estimate(y, dt), rel=1e-9)
    two = FirstDifferences(1)
    for k, value in enumerate(y):
        if k == 250:
            two.break_chain()
        two.add(100.0 + k * dt, np.array([value]))
    assert two.n == 498
    halves = FirstDifferences(1)
    halves.add_series(y[:250])
    halves.add_series(y[250:])
    assert halves.density(dt)[0] == pytest.approx(two.density()[0], rel=1e-9)


@pytest.fixture(scope="module")
def replayed() -> tuple[OnlineIdentifier, object]:
    """A stand (25 s) – drive (20 s) – stand (20 s) run at 200 Hz IMU / 50 Hz odometry through the identifier."""
    run = simulate_demo_run(3, stand_before=25, drive=20, stand_after=20)  # biases GYRO_BIAS, ACCEL_BIAS
    ident = OnlineIdentifier(hypotheses=read_hypotheses_file(None))
    i = j = 0
    ni, nj = len(run.imu_t), len(run.odom_t)
    corrected = []
    while i < ni or j < nj:
        if j >= nj or (i < ni and run.imu_t[i] <= run.odom_t[j]):
            corrected.extend(ident.process_imu(run.imu_t[i], tuple(run.gyro[i]), tuple(run.accel[i]), "imu_link",
                                               float(i) / 200))
            i += 1
            if i % 20 == 0:
                ident.update_identification()
        else:
            ident.process_odometry(
                run.odom_t[j], tuple(run.linear_velocity[j]), tuple(run.angular_velocity[j]), "base_link",
                float(j) / 50, position=tuple(run.position[j]), orientation_xyzw=tuple(run.orientation_xyzw[j]),
                pose_covariance=run.pose_cov[j].ravel(), twist_covariance=run.twist_cov[j].ravel(),
            )
            j += 1
    ident.update_identification()
    return ident, run, corrected


def test_replay_recovers_biases_and_noise(replayed):
    ident, _, _ = replayed
    est = ident.estimates()
    assert est.cmkf_status == "tracking"
    # Biases: within 4 posterior standard deviations and within an absolute bound a robot user cares about.
    for value, std, truth, bound in ((est.gyro_bias, est.gyro_bias_std, GYRO_BIAS, 2e-3),
                                     (est.accel_bias, est.accel_bias_std, ACCEL_BIAS, 0.02)):
        assert np.all(np.abs(value - truth) < 4 * std)
        assert np.all(np.abs(value - truth) < bound)
    # ~7000 stationary differences: rstd ≈ 1 %; 5 % leaves room for the slow start/stop of the drive.
    truth = np.array([1e-3] * 3 + [1e-2] * 3)
    assert np.all(np.abs(est.noise_density / truth - 1) < 0.05)
    assert est.covariance_source == "stationary"
    np.testing.assert_allclose(est.covariance, est.noise_density**2 * 200.0, rtol=1e-3)
    assert est.noise_samples > 6000
    # Two stationary stretches, one drive: the guard and hysteresis leave exactly two entries.
    assert ident.stationarity.transitions in (3, 4)


def test_replay_feeds_the_bank_only_while_stationary(replayed):
    ident, _, _ = replayed
    report = ident.hypotheses()
    assert report is not None and report.names == ("WN+RW", "WN+GM")
    np.testing.assert_allclose(report.probabilities.sum(axis=1), 1.0, rtol=1e-9)
    # 10 Hz bank samples from at most the 45 s of standing (minus hysteresis and guard), none from the drive.
    assert np.all(report.updates > 300)
    assert np.all(report.updates <= 450)
    fields, table = ident.estimates().noise_table()
    wn = table[:, fields.index("bank_WN.noise_density")]
    truth = np.array([1e-3] * 3 + [1e-2] * 3)
    assert np.all(np.abs(wn / truth - 1) < 0.25)  # the grid's cells are ~50 % apart: within one cell


def test_corrected_samples_have_biases_removed_and_covariances(replayed):
    ident, run, corrected = replayed
    last = corrected[-1]
    # The biases at that sample are those of the previous odometry update (they move by < 1e-4 per update).
    assert np.all(np.abs(np.array(last.gyro) - (run.gyro[-1] - ident.cmkf_feed.gyro_bias)) < 1e-4)
    assert np.all(np.abs(np.array(last.accel) - (run.accel[-1] - ident.cmkf_feed.accel_bias)) < 1e-3)
    tail = np.array([c.gyro for c in corrected[-2000:]])
    assert np.all(np.abs(tail.mean(axis=0)) < 1e-3)  # standing still: the corrected rate averages to ~0
    assert last.gyro_variance == pytest.approx(tuple(ident.estimates().covariance[:3]), rel=0.05)


def test_bad_messages_are_dropped_counted_and_reported():
    ident = OnlineIdentifier()
    [ok] = ident.process_imu(10.0, (0.0, 0.0, 0.0), (0.0, 0.0, 9.8), "imu", 0.0)
    assert ok is not None and ok.gyro_variance is None  # no noise estimate yet: REP-145 "unknown"
    assert ident.process_imu(10.01, (math.nan, 0.0, 0.0), (0.0, 0.0, 9.8), "imu", 0.0) == []
    assert ident.process_imu(10.0, (0.0, 0.0, 0.0), (0.0, 0.0, 9.8), "imu", 0.0) == []  # duplicate
    assert ident.process_imu(9.0, (0.0, 0.0, 0.0), (0.0, 0.0, math.inf), "imu", 0.0) == []
    assert ident.process_imu(9.5, (0.0, 0.0, 0.0), (0.0, 0.0, 9.8), "imu", 0.0) == []  # backward
    assert len(ident.process_imu(10.02, (0.0, 0.0, 0.0), (0.0, 0.0, 9.8), "imu_other", 0.0)) == 1
    assert not ident.process_odometry(0.0, (0.0,) * 3, (0.0,) * 3, "base", 0.0)  # zero stamp
    assert not ident.process_odometry(10.0, (math.nan,) * 3, (0.0,) * 3, "base", 0.0)
    keys = {key for key, _ in ident.pop_events()}
    assert {"imu_nonfinite", "imu_duplicate", "imu_backward", "imu_frame", "odom_bad_stamp",
            "odom_nonfinite"} <= keys
    statuses = {s.name: s for s in ident.diagnostics(0.5, 1.0)}
    assert statuses["Time stamps"].level == WARN
    assert "1 imu backward" in statuses["Time stamps"].message
    assert statuses["IMU input"].level == WARN and "frame_id changed" in statuses["IMU input"].message
    assert statuses["IMU input"].values["rejected_nonfinite"] == "2"
    # After the window, the stamp problems are no longer current.
    assert {s.name: s.level for s in ident.diagnostics(0.6, 1.0)}["Time stamps"] == OK


def test_diagnostics_report_stale_inputs_and_estimates_out_of_range(replayed):
    fresh = {s.name: s for s in OnlineIdentifier().diagnostics(100.0, 1.0)}
    assert fresh["IMU input"].level == STALE
    assert fresh["Odometry input"].level == WARN
    ident, _, _ = replayed
    statuses = {s.name: s for s in ident.diagnostics(1e6, 1.0)}  # long after the last message
    assert statuses["IMU input"].level == STALE and "no message for" in statuses["IMU input"].message
    assert statuses["Estimate ranges"].level == OK
    assert statuses["Filter consistency"].level in (OK, WARN)
    assert statuses["Filter consistency"].level != ERROR
    ident.set_config(ident.config.updated({"expected.gyro_bias_max": 1e-4}))
    ranges = {s.name: s for s in ident.diagnostics(1e6, 1.0)}["Estimate ranges"]
    assert ranges.level == WARN and "gyro_y bias" in ranges.message
    ident.set_config(ident.config.updated({"expected.gyro_bias_max": 0.1}))


def test_a_sustained_jump_back_in_time_starts_a_new_time_line():
    ident = OnlineIdentifier(OnlineConfig({"backward_reset_count": 5}))
    for k in range(100):
        ident.process_imu(100.0 + k * 0.01, (0.0, 0.0, 0.0), (0.0, 0.0, 9.8))
    results = [ident.process_imu(1.0 + k * 0.01, (0.0, 0.0, 0.0), (0.0, 0.0, 9.8)) for k in range(10)]
    assert [len(r) for r in results] == [0] * 4 + [1] * 6
    assert ident.restarts == 1


def test_monitor_once_tells_a_silent_node_from_one_without_imu_input():
    from imu_noise_id.ros.monitor import MonitorState, silence_message

    state = MonitorState(node="/imu_noise_id_node")
    assert "is it running" in silence_message(state, 10.0)
    state.diagnostics["IMU input"] = (3, "no message received yet")
    message = silence_message(state, 10.0)
    assert "is running but published no estimates within 10 s" in message
    assert "(its IMU input status: no message received yet)" in message and "-r imu/data:=TOPIC" in message


def test_monitor_render_shows_every_section():
    from imu_noise_id.ros.monitor import MonitorState, render

    fields = ["noise_density", "bias", "bias_std", "bank_WN.noise_density"]
    rows = [[1e-3, 0.004, 5e-4, 9e-4]] * 6
    state = MonitorState(node="/imu_noise_id_node", gyro_bias=(0.004, 0, 0), accel_bias=(0, 0, 0),
                         noise=(["gyro_x"] * 6, fields, rows),
                         hypotheses=(["gyro_x"] * 6, ["WN+RW", "WN+GM", "decision", "bank_updates"],
                                     [[0.9, 0.1, 0.0, 12.0]] * 6),
                         diagnostics={"IMU input": (OK, "200 Hz"), "Time stamps": (WARN, "1 imu backward")})
    text = render(state)
    assert "4.000e-03" in text and "5.000e-04" in text
    assert "WN.noise_density" in text
    assert "0.900" in text and "WN+RW" in text
    assert "WARN  Time stamps: 1 imu backward" in text
    assert state.complete()


def test_play_loads_a_bag_in_time_order_and_rejects_unknown_topics(tmp_path):
    from imu_noise_id.bag.writer import write_robot_bag
    from imu_noise_id.demo.online import simulate_demo_run
    from imu_noise_id.ros.play import load_messages

    run = simulate_demo_run(stand_before=1.0, drive=1.0, stand_after=1.0)
    bag = write_robot_bag(run, tmp_path / "bag")
    messages = load_messages(bag, None)
    assert len(messages) == len(run.imu_t) + len(run.odom_t)
    stamps = [m[0] for m in messages]
    assert stamps == sorted(stamps)
    assert {m[1] for m in messages} == {"/imu/data", "/odom"}
    assert len(load_messages(bag, ["/odom"])) == len(run.odom_t)
    with pytest.raises(InputError, match="not in"):
        load_messages(bag, ["/nope"])
    with pytest.raises(InputError, match="does not exist"):
        load_messages(tmp_path / "missing", None)


def test_odometry_arriving_after_later_imu_samples_is_processed_in_stamp_order():
    """Odometry delivered up to 60 ms after IMU samples with later stamps (two topics, two latencies): the CMKF
    still sees stamp order (without the reordering it raised LinAlgError on such input)."""
    run = simulate_demo_run(5, stand_before=5, drive=10, stand_after=5)
    rng = np.random.default_rng(6)
    arrival = np.maximum.accumulate(run.odom_t + 0.06 * rng.random(run.odom_t.size))  # one topic keeps its order
    events = [(t, 0, k) for k, t in enumerate(arrival)]
    events += [(t, 1, k) for k, t in enumerate(run.imu_t)]
    ident = OnlineIdentifier()
    for _, kind, k in sorted(events):
        if kind:
            ident.process_imu(run.imu_t[k], tuple(run.gyro[k]), tuple(run.accel[k]))
        else:
            ident.process_odometry(run.odom_t[k], tuple(run.linear_velocity[k]), tuple(run.angular_velocity[k]),
                                   position=tuple(run.position[k]), orientation_xyzw=tuple(run.orientation_xyzw[k]),
                                   twist_covariance=run.twist_cov[k].ravel())
    assert ident.cmkf_feed.errors == 0
    est = ident.estimates()
    assert est.cmkf_status == "tracking"
    assert ident.cmkf_feed.cmkf.counters["updates"] >= len(run.odom_t) - 10


def test_without_odometry_the_imu_alone_decides_and_the_noise_is_still_identified():
    rng = np.random.default_rng(8)
    ident = OnlineIdentifier(hypotheses=read_hypotheses_file(None))
    dt = 0.005
    for k in range(4000):  # 20 s standing, no odometry at all
        gyro = rng.normal(0.0, 1e-3 / math.sqrt(dt), 3) + 0.002
        accel = rng.normal(0.0, 1e-2 / math.sqrt(dt), 3) + np.array([0.0, 0.0, 9.81])
        ident.process_imu(100.0 + k * dt, tuple(gyro), tuple(accel))
        if k % 20 == 0:
            ident.update_identification()
    est = ident.estimates()
    assert est.stationary and est.cmkf_status == "imu_only"
    assert np.all(np.isnan(est.gyro_bias))  # nothing to estimate a bias against: not published as a number
    truth = np.array([1e-3] * 3 + [1e-2] * 3)
    assert np.all(np.abs(est.noise_density / truth - 1) < 0.06)  # ~3000 differences: rstd ≈ 1.6 %
    assert est.covariance_source == "stationary"
    statuses = {s.name: s for s in ident.diagnostics(0.0, 1.0)}
    assert statuses["Filter consistency"].level == WARN and "needs IMU and odometry" in statuses[
        "Filter consistency"].message
    assert ident.hypotheses() is not None and np.all(ident.hypotheses().updates > 100)


def test_odometry_later_than_the_input_latency_is_dropped_not_fatal():
    run = simulate_demo_run(9, stand_before=3, drive=4, stand_after=3)
    ident = OnlineIdentifier(OnlineConfig({"cmkf.input_latency": 0.02}))
    events = [(t + 0.03, 0, k) for k, t in enumerate(run.odom_t)]  # always 30 ms late: beyond the 20 ms window
    events += [(t, 1, k) for k, t in enumerate(run.imu_t)]
    for _, kind, k in sorted(events):
        if kind:
            ident.process_imu(run.imu_t[k], tuple(run.gyro[k]), tuple(run.accel[k]))
        else:
            ident.process_odometry(run.odom_t[k], tuple(run.linear_velocity[k]), tuple(run.angular_velocity[k]),
                                   position=tuple(run.position[k]), orientation_xyzw=tuple(run.orientation_xyzw[k]))
    assert ident.cmkf_feed.errors == 0
    assert ident.cmkf_feed.too_late >= len(run.odom_t) - 2  # the last ones may still wait in the queue
    status = {s.name: s for s in ident.diagnostics(0.0, 1.0)}["Time stamps"]
    assert status.level == WARN and "odom too late" in status.message


def test_play_converts_ros1_messages_to_the_ros2_types(shared_data):
    """The ROS 1 Husky bag and its rosbag2 copy give the same ROS 2 messages (ROS 1 Header.seq dropped)."""
    pytest.importorskip("rclpy")
    from rclpy.serialization import deserialize_message

    from imu_noise_id.ros.play import load_messages, message_class, to_rclpy

    folder = shared_data / "husky_robot_localization"
    if not (folder / "test1.bag").is_file():
        pytest.skip("the Husky ROS 1 bag is absent")
    topics = ["/imu/data", "/husky_velocity_controller/odom"]
    ros1 = load_messages(folder / "test1.bag", topics)
    ros2 = load_messages(folder / "husky_test1_ros2", topics)
    assert len(ros1) == len(ros2)
    for k in (0, 1, 2, 500, len(ros1) - 1):
        t1, topic1, kind, obj = ros1[k]
        t2, topic2, _, raw = ros2[k]
        assert (t1, topic1) == (t2, topic2)
        cls = message_class(kind)
        assert to_rclpy(obj, cls) == deserialize_message(raw, cls)


def _filter_innovations_status(vibration: float) -> object:
    """The 'Filter innovations' status after a simulated robot (60 s, IMU 100 Hz, odometry 10 Hz) with a 1.3 Hz
    specific-force oscillation of ``vibration`` m/s² on the IMU's y axis, which no filter model contains."""
    from imu_noise_id.core.cmkf.merge import stamp_order
    from imu_noise_id.core.simulation.robot import simulate_robot

    run = simulate_robot(60.0, np.random.default_rng(1))
    accel = run.accel.copy()
    accel[:, 1] += vibration * np.sin(2 * math.pi * 1.3 * run.imu_t)
    ident = OnlineIdentifier(OnlineConfig({"cmkf.imu_rotation_xyzw": run.imu_rotation_xyzw,
                                           "innovations.window": 300}))
    for is_odometry, k in stamp_order(run.imu_t, run.odom_t):
        if is_odometry:
            ident.process_odometry(100.0 + run.odom_t[k], tuple(run.linear_velocity[k]),
                                   tuple(run.angular_velocity[k]), orientation_xyzw=tuple(run.orientation_xyzw[k]),
                                   twist_covariance=run.twist_cov[k].ravel())
        else:
            ident.process_imu(100.0 + run.imu_t[k], tuple(run.gyro[k]), tuple(accel[k]))
    return {s.name: s for s in ident.diagnostics(0.0, 1.0)}["Filter innovations"]


def test_unmodelled_vibration_reaches_the_diagnostics_as_correlated_innovations():
    """The InnovationMonitors on the CMKF's and the gyro filter's innovations make the 'Filter innovations' status:
    white and consistent on the simulated robot; 'model inadequate: accel_y: residuals correlated at lag …' with a
    0.05 m/s² vibration (about 5 σ of the accelerometer noise over an odometry interval)."""
    clean = _filter_innovations_status(0.0)
    assert clean.level == OK and "white and consistent" in clean.message
    assert clean.values["channels_tested"] == "6/6"
    shaken = _filter_innovations_status(0.05)
    assert shaken.level == WARN
    assert shaken.message.startswith("model inadequate: accel_y: residuals correlated at lag")
    assert float(shaken.values["accel_y_ljung_box_p"]) < 1e-10 and float(shaken.values["gyro_z_ljung_box_p"]) > 1e-4
    with pytest.raises(InputError, match="innovations"):
        OnlineIdentifier(OnlineConfig({"innovations.window": 50, "innovations.lags": 20}))


def test_the_cli_parses_arguments_only_and_the_monitor_does_not_import_the_node():
    """cli/play.py and cli/monitor.py only parse arguments and call imu_noise_id.ros: importing them (and the
    monitor's view) loads neither rclpy nor the node."""
    import os
    import subprocess
    import sys

    code = ("import sys, imu_noise_id.cli.monitor, imu_noise_id.cli.play, imu_noise_id.ros.monitor; "
            "print(sorted(m for m in ('rclpy', 'imu_noise_id.ros.node', 'imu_noise_id.ros.play') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=REPO_ROOT, env={**os.environ, "PYTHONPATH": str(REPO_ROOT)})
    assert out.stdout.strip() == "[]"
