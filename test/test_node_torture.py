"""The node survives a scripted torture run over DDS on loopback (issue 12, "Done when").

The node runs as its own process (own DDS domain, the packaged parameters plus an integer override and a misspelled
name); this test process publishes a simulated robot (stand, drive, stand; known biases and noise) with damage
mixed in — absurd, NaN and infinite values, a bump at full scale, a clipped sensor, a burst of host-stamped
messages, a rate drop, a stamp an hour ahead, a stamp in the past, bad odometry — and sets parameters at runtime
(good, out of range, of the wrong type, unknown, start-up only). Afterwards the node must be alive, its biases and
``~/imu_corrected`` (values and covariances) sane, and its diagnostics and log must name what happened. A bad
parameter at start-up must stop it with one line and exit code 2.
"""

from __future__ import annotations

import math
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")

from dds import domain_id  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue  # noqa: E402
from rcl_interfaces.srv import SetParameters  # noqa: E402
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402
from sensor_msgs.msg import Imu  # noqa: E402
from test_node import Observer  # noqa: E402

from imu_noise_id.demo.online import DEMO_TRUTH, simulate_demo_run  # noqa: E402
from imu_noise_id.resources import NODE_PARAMETERS, packaged_config  # noqa: E402
from imu_noise_id.ros.launch import node_command, stop  # noqa: E402

pytestmark = pytest.mark.ros
NODE = "/imu_noise_id_node"
IMU_RATE, ODOM_RATE, SPEED = 100.0, 20.0, 2.0  # simulated rates [Hz]; played 2× faster than real time


def _stamp(msg, t: float) -> None:
    sec = math.floor(t)
    msg.header.stamp.sec = int(sec)
    msg.header.stamp.nanosec = min(round((t - sec) * 1e9), 999_999_999)


def _imu(t: float, gyro, accel) -> Imu:
    msg = Imu()
    msg.header.frame_id = "imu_link"
    _stamp(msg, t)
    msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z = (float(v) for v in gyro)
    msg.linear_acceleration.x, msg.linear_acceleration.y, msg.linear_acceleration.z = (float(v) for v in accel)
    return msg


def _odom(run, j: int, t: float | None = None, twist=None, quaternion=None) -> Odometry:
    msg = Odometry()
    msg.header.frame_id, msg.child_frame_id = "odom", "base_link"
    _stamp(msg, run.odom_t[j] if t is None else t)
    v, w = run.linear_velocity[j], run.angular_velocity[j]
    if twist is not None:
        v = twist
    msg.twist.twist.linear.x, msg.twist.twist.linear.y, msg.twist.twist.linear.z = (float(x) for x in v)
    msg.twist.twist.angular.x, msg.twist.twist.angular.y, msg.twist.twist.angular.z = (float(x) for x in w)
    q = run.orientation_xyzw[j] if quaternion is None else quaternion
    o = msg.pose.pose.orientation
    o.x, o.y, o.z, o.w = (float(x) for x in q)
    msg.twist.covariance = run.twist_cov[j].ravel().tolist()
    return msg


def torture_script(run) -> tuple[list[tuple[float, str, object]], dict[str, int]]:
    """(play time [s], topic, message) of the whole run with the damage mixed in, and where the damage is."""
    k = {name: round(t * IMU_RATE) for name, t in (("absurd", 6.0), ("burst", 8.0), ("future", 9.0),
                                                    ("past", 9.5), ("bump", 30.0), ("clip", 31.0),
                                                    ("drop", 34.0))}
    out: list[tuple[float, str, object]] = []
    skip = set(range(k["drop"], k["drop"] + 300)) - set(range(k["drop"], k["drop"] + 300, 20))  # 100 Hz → 5 Hz
    for i, t in enumerate(run.imu_t):
        if i in skip:
            continue
        gyro, accel = run.gyro[i].copy(), run.accel[i].copy()
        stamp = t
        if k["burst"] <= i < k["burst"] + 20:  # host-stamped burst: 20 messages 0.1 ms apart
            stamp = run.imu_t[k["burst"] + 19] + 1e-4 * (i - k["burst"] - 19)
        if i == k["future"]:
            stamp = t + 3600.0
        if i == k["past"]:
            stamp = t - 5.0
        if i == k["bump"]:
            gyro[0] += 35.0
            accel[0] += 157.0
        if k["clip"] <= i < k["clip"] + 5:
            gyro[2] = 34.906585
        out.append((t - run.imu_t[0], "imu", _imu(stamp, gyro, accel)))
    for name, values in (("absurd", ((1e10, 0, 0), (0, 0, 9.8))), ("absurd", ((0, 0, 0), (0, 0, 1e300))),
                         ("absurd", ((math.nan, 0, 0), (0, 0, 9.8))), ("absurd", ((0, 0, 0), (math.inf, 0, 9.8)))):
        out.append((run.imu_t[k[name]] - run.imu_t[0] + 1e-4, "imu", _imu(run.imu_t[k[name]] + 1e-3, *values)))
    for j, t in enumerate(run.odom_t):
        out.append((t - run.imu_t[0], "odom", _odom(run, j)))
    j = round(12.0 * ODOM_RATE)  # bad odometry while driving
    out += [(run.odom_t[j] - run.imu_t[0] + 1e-4, "odom", _odom(run, j, run.odom_t[j] + 1e-3, twist=(math.nan,) * 3)),
            (run.odom_t[j + 1] - run.imu_t[0] + 1e-4, "odom", _odom(run, j + 1, run.odom_t[j + 1] + 3600.0)),
            (run.odom_t[j + 2] - run.imu_t[0] + 1e-4, "odom", _odom(run, j + 2, run.odom_t[j + 2] + 1e-3,
                                                                     quaternion=(0.0, 0.0, 0.0, 0.0)))]
    out.sort(key=lambda item: item[0])
    return out, k


def _set(obs: Observer, name: str, kind: int, **value) -> tuple[bool, str]:
    client = obs.node.create_client(SetParameters, f"{NODE}/set_parameters")
    assert client.wait_for_service(timeout_sec=10.0)
    future = client.call_async(SetParameters.Request(
        parameters=[Parameter(name=name, value=ParameterValue(type=kind, **value))]))
    assert obs.spin_until(future.done, 10.0)
    obs.node.destroy_client(client)
    result = future.result().results[0]
    return result.successful, result.reason


@pytest.fixture(scope="module")
def domain_env(ros_env) -> dict[str, str]:
    return {**ros_env, "ROS_DOMAIN_ID": str(domain_id(100, 180))}


@pytest.fixture(scope="module")
def tortured(tmp_path_factory, domain_env):
    run = simulate_demo_run(5, stand_before=12.0, drive=12.0, stand_after=16.0, imu_rate=IMU_RATE,
                            odom_rate=ODOM_RATE)
    script, where = torture_script(run)
    work = tmp_path_factory.mktemp("torture")
    log = open(work / "node.log", "w")  # noqa: SIM115 - closed in the teardown
    node = subprocess.Popen(node_command(packaged_config(NODE_PARAMETERS), "-p", "publish_rate:=20",
                                         "-p", "stationary.windw:=2.0"),
                            env=domain_env, stdout=log, stderr=subprocess.STDOUT)
    rclpy.init(domain_id=int(domain_env["ROS_DOMAIN_ID"]))
    obs = Observer()
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE)
    publishers = {"imu": obs.node.create_publisher(Imu, "/imu/data", qos),
                  "odom": obs.node.create_publisher(Odometry, "/odom", qos)}
    params = {}
    try:
        assert obs.spin_until(lambda: all(p.get_subscription_count() for p in publishers.values()), 30.0), \
            "the node did not come up"
        obs.spin_until(lambda: False, 0.5)
        start = time.monotonic()
        changed = False
        for t, topic, msg in script:
            delay = start + t / SPEED - time.monotonic()
            if delay > 0:
                obs.spin_until(lambda: False, delay)
            publishers[topic].publish(msg)
            if not changed and t > 20.0:  # parameters while driving
                changed = True
                params["good"] = _set(obs, "expected_imu_rate", ParameterType.PARAMETER_DOUBLE, double_value=100.0)
                params["integer"] = _set(obs, "gap_factor", ParameterType.PARAMETER_INTEGER, integer_value=12)
                params["range"] = _set(obs, "stationary.window", ParameterType.PARAMETER_DOUBLE, double_value=-1.0)
                params["type"] = _set(obs, "odom_timeout", ParameterType.PARAMETER_STRING, string_value="fast")
                params["nan"] = _set(obs, "gap_factor", ParameterType.PARAMETER_DOUBLE, double_value=math.nan)
                params["startup"] = _set(obs, "publish_rate", ParameterType.PARAMETER_DOUBLE, double_value=5.0)
        obs.spin_until(lambda: False, 2.5)  # the last publish and diagnostics periods
        yield {"run": run, "script": script, "where": where, "node": node, "obs": obs, "params": params,
               "log": work / "node.log"}
    finally:
        stop(node)
        log.close()
        obs.node.destroy_node()
        rclpy.shutdown()


def test_the_node_is_alive_and_answers(tortured):
    assert tortured["node"].poll() is None
    sent = sum(1 for _, topic, _ in tortured["script"] if topic == "imu")
    # best effort on a loaded machine may lose a few; this process may fall behind the corrected stream
    assert int(tortured["obs"].statuses()["IMU input"][2]["received"]) > 0.98 * sent
    assert len(tortured["obs"].corrected) > 0.5 * sent


def test_biases_are_sane_after_the_torture(tortured):
    obs = tortured["obs"]
    g, a = obs.last["gyro_bias"].vector, obs.last["accel_bias"].vector
    assert np.all(np.abs(np.array([g.x, g.y, g.z]) - DEMO_TRUTH["gyro_bias"]) < 2e-3)
    assert np.all(np.abs(np.array([a.x, a.y, a.z]) - DEMO_TRUTH["accel_bias"]) < 0.03)


def test_the_corrected_imu_values_and_covariances_are_sane(tortured):
    run, obs = tortured["run"], tortured["obs"]
    by_stamp = {round(t * 1e6): k for k, t in enumerate(run.imu_t)}
    after = round(run.imu_t[tortured["where"]["drop"] + 400] * 1e6)  # after the last damage
    last = [m for m in obs.corrected if after < round((m.header.stamp.sec + m.header.stamp.nanosec * 1e-9) * 1e6)]
    assert len(last) > 50
    truth_g, truth_a = np.array(DEMO_TRUTH["gyro_bias"]), np.array(DEMO_TRUTH["accel_bias"])
    for msg in last:
        k = by_stamp[round((msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9) * 1e6)]
        w, a = msg.angular_velocity, msg.linear_acceleration
        assert np.all(np.abs(np.array([w.x, w.y, w.z]) - (run.gyro[k] - truth_g)) < 2e-3)
        assert np.all(np.abs(np.array([a.x, a.y, a.z]) - (run.accel[k] - truth_a)) < 0.03)
    cov_g = np.diag(np.array(last[-1].angular_velocity_covariance).reshape(3, 3))
    cov_a = np.diag(np.array(last[-1].linear_acceleration_covariance).reshape(3, 3))
    # N²·f at the nominal 100 Hz; ~2000 stationary differences
    np.testing.assert_allclose(cov_g, DEMO_TRUTH["gyro_noise_density"] ** 2 * IMU_RATE, rtol=0.15)
    np.testing.assert_allclose(cov_a, DEMO_TRUTH["accel_noise_density"] ** 2 * IMU_RATE, rtol=0.15)


def test_the_diagnostics_name_what_happened(tortured):
    statuses = tortured["obs"].statuses()
    imu, stamps = statuses["IMU input"][2], statuses["Time stamps"][2]
    assert int(imu["rejected_nonfinite"]) >= 4  # 1e10, 1e300, NaN, inf
    assert int(imu["saturated_samples"]) >= 2  # five clipped samples: the repeats of the extreme
    assert int(stamps["total_imu_outlier"]) >= 1 and int(stamps["total_imu_backward"]) >= 1
    assert int(stamps["total_odom_outlier"]) >= 1
    assert float(imu["rate_header_hz"]) == pytest.approx(IMU_RATE, rel=0.05)
    consistency = statuses["Filter consistency"][2]
    assert int(consistency["cmkf_gated_gyro"]) >= 1 and int(consistency["cmkf_gated_accel"]) >= 1
    assert int(consistency["cmkf_odom_dropped_orientation"]) == 1
    assert int(statuses["Odometry input"][2]["rejected_nonfinite"]) == 1
    assert int(statuses["Noise density"][2]["stationary_samples"]) > 1000


def test_runtime_parameters_good_bad_and_start_up_only(tortured):
    params = tortured["params"]
    assert params["good"][0] and params["integer"][0]
    for key in ("range", "type", "nan", "startup"):
        ok, reason = params[key]
        assert not ok and reason, key


def test_the_log_names_the_problems_and_holds_no_traceback(tortured):
    text = Path(tortured["log"]).read_text()
    assert "Traceback" not in text and "not processed" not in text
    for fragment in ("unknown parameter 'stationary.windw'", "rejected by the innovation gate", "full scale",
                     "isolated outlier", "non-finite"):
        assert fragment in text, fragment


def test_a_bad_parameter_at_start_up_is_one_line_and_exit_2(domain_env):
    proc = subprocess.run([*node_command(packaged_config(NODE_PARAMETERS)), "-p", "imu_range.gyro:=-5.0"],
                          env=domain_env, capture_output=True, text=True, timeout=60, check=False)
    assert proc.returncode == 2 and "imu_range.gyro" in proc.stderr and "Traceback" not in proc.stderr

