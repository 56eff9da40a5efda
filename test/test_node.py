"""End to end with real DDS on loopback: the node as its own process, a bag played from another process.

The node runs ``python -m imu_noise_id.ros.node --ros-args --params-file config/imu_noise_id.yaml``; a simulated robot
(stand 15 s, drive 10 s, stand 10 s; known biases and white-noise densities, :data:`DEMO_TRUTH`) is played with
``imu-noise-id play --rate 2``; this test process subscribes to the outputs, then sends bad messages and changes
parameters at runtime.
"""

from __future__ import annotations

import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")

from dds import domain_id  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from geometry_msgs.msg import Vector3Stamped  # noqa: E402
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue  # noqa: E402
from rcl_interfaces.srv import SetParameters  # noqa: E402
from rclpy.qos import QoSProfile, ReliabilityPolicy  # noqa: E402
from sensor_msgs.msg import Imu  # noqa: E402
from std_msgs.msg import Float64MultiArray  # noqa: E402

from imu_noise_id.bag.writer import write_robot_bag  # noqa: E402
from imu_noise_id.demo.online import DEMO_TRUTH, simulate_demo_run  # noqa: E402
from imu_noise_id.pipelines.online.results import HYPOTHESES_EXTRA_COLUMNS  # noqa: E402
from imu_noise_id.resources import NODE_PARAMETERS, packaged_config  # noqa: E402
from imu_noise_id.ros.launch import node_command, stop  # noqa: E402
from imu_noise_id.ros.messages import parse_labelled  # noqa: E402

NODE_CONFIG = packaged_config(NODE_PARAMETERS)

pytestmark = pytest.mark.ros
NODE = "/imu_noise_id_node"
RATE = 2.0


class Observer:
    """An rclpy node in this test process collecting everything the node under test publishes."""

    def __init__(self, node_name: str = NODE) -> None:
        self.node = rclpy.create_node("imu_noise_id_test_observer")
        self.last: dict[str, object] = {}
        self.corrected: list[Imu] = []
        self.diagnostics: list[DiagnosticArray] = []
        prefix = node_name.lstrip("/") + ": "
        self.prefix = prefix
        for name, kind in (("gyro_bias", Vector3Stamped), ("accel_bias", Vector3Stamped),
                           ("noise", Float64MultiArray), ("hypotheses", Float64MultiArray)):
            self.node.create_subscription(kind, f"{node_name}/{name}",
                                          lambda msg, key=name: self.last.__setitem__(key, msg), 10)
        self.node.create_subscription(Imu, f"{node_name}/imu_corrected", self.corrected.append,
                                      QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE))
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self.diagnostics.append, 50)

    def spin_until(self, condition, timeout: float) -> bool:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if condition():
                return True
            rclpy.spin_once(self.node, timeout_sec=0.05)
        return condition()

    def statuses(self) -> dict[str, tuple[int, str, dict[str, str]]]:
        """The latest status of each function of the node under test."""
        out = {}
        for array in self.diagnostics:
            for s in array.status:
                if s.name.startswith(self.prefix):
                    out[s.name[len(self.prefix):]] = (s.level[0], s.message, {kv.key: kv.value for kv in s.values})
        return out

    def column(self, name: str) -> np.ndarray:
        _, cols, rows = parse_labelled(self.last["noise"])
        return np.array([row[cols.index(name)] for row in rows])


@pytest.fixture(scope="module")
def domain_env(ros_env) -> dict[str, str]:
    """The subprocess environment on a DDS domain of its own, so that concurrent runs cannot cross-talk."""
    return {**ros_env, "ROS_DOMAIN_ID": str(domain_id(10, 99))}


@pytest.fixture(scope="module")
def ros_context(domain_env):
    rclpy.init(domain_id=int(domain_env["ROS_DOMAIN_ID"]))
    yield
    rclpy.shutdown()


@pytest.fixture(scope="module")
def session(tmp_path_factory, domain_env, ros_context):
    ros_env = domain_env
    work = tmp_path_factory.mktemp("node")
    run = simulate_demo_run(stand_before=15.0, drive=10.0, stand_after=10.0)
    bag = write_robot_bag(run, work / "robot_bag")
    log = open(work / "node.log", "w")  # noqa: SIM115 - closed in the teardown
    node = subprocess.Popen(node_command(NODE_CONFIG), env=ros_env, stdout=log, stderr=subprocess.STDOUT)
    observer = Observer()
    try:
        assert observer.spin_until(lambda: observer.node.count_publishers(f"{NODE}/imu_corrected") > 0, 30.0), \
            "the node did not come up"
        observer.spin_until(lambda: False, 0.5)  # let the node's publishers match our subscriptions
        player = subprocess.Popen(
            [sys.executable, "-m", "imu_noise_id", "play", str(bag), "--rate", str(RATE), "--quiet", "--delay",
             "10"], env=ros_env,
        )
        observer.spin_until(lambda: player.poll() is not None, 90.0)
        assert player.returncode == 0
        observer.spin_until(lambda: False, 1.5)  # the last publish and diagnostics periods
        yield {"run": run, "node": node, "observer": observer, "log": work / "node.log"}
    finally:
        stop(node)
        log.close()
        observer.node.destroy_node()


def test_the_node_receives_everything_and_corrects_each_sample(session):
    run, obs = session["run"], session["observer"]
    sent = len(run.imu_t)
    # Sensor-data QoS with a deep queue: nothing should be lost on loopback at 400 Hz.
    assert int(obs.statuses()["IMU input"][2]["received"]) >= 0.995 * sent
    # This test process (a Python subscriber on a loaded machine) may itself fall behind the 400 Hz stream.
    assert len(obs.corrected) >= 0.9 * sent
    by_stamp = {round(t * 1e6): k for k, t in enumerate(run.imu_t)}
    truth_g, truth_a = np.array(DEMO_TRUTH["gyro_bias"]), np.array(DEMO_TRUTH["accel_bias"])
    last = obs.corrected[-200:]
    for msg in last:
        k = by_stamp[round((msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9) * 1e6)]
        w, a = msg.angular_velocity, msg.linear_acceleration
        # Corrected = raw − estimated bias; the estimate is within ~1e-3 rad/s and ~0.02 m/s² of the truth.
        assert np.all(np.abs(np.array([w.x, w.y, w.z]) - (run.gyro[k] - truth_g)) < 2e-3)
        assert np.all(np.abs(np.array([a.x, a.y, a.z]) - (run.accel[k] - truth_a)) < 0.03)
    cov_g = np.array(last[-1].angular_velocity_covariance).reshape(3, 3)
    cov_a = np.array(last[-1].linear_acceleration_covariance).reshape(3, 3)
    # N²·f with N = 1e-3 rad/s/√Hz, 1e-2 m/s²/√Hz at 200 Hz; ~4000 stationary differences: rstd ≈ 1.4 %.
    np.testing.assert_allclose(np.diag(cov_g), DEMO_TRUTH["gyro_noise_density"] ** 2 * 200, rtol=0.08)
    np.testing.assert_allclose(np.diag(cov_a), DEMO_TRUTH["accel_noise_density"] ** 2 * 200, rtol=0.08)
    assert np.count_nonzero(cov_g - np.diag(np.diag(cov_g))) == 0
    assert last[-1].header.frame_id == "imu_link"


def test_published_biases_and_noise_converge_to_the_truth(session):
    obs = session["observer"]
    g, a = obs.last["gyro_bias"].vector, obs.last["accel_bias"].vector
    gyro = np.array([g.x, g.y, g.z])
    accel = np.array([a.x, a.y, a.z])
    std = obs.column("bias_std")
    for value, sigma, truth, bound in ((gyro, std[:3], DEMO_TRUTH["gyro_bias"], 2e-3),
                                       (accel, std[3:], DEMO_TRUTH["accel_bias"], 0.02)):
        err = np.abs(value - np.array(truth))
        assert np.all(err < 4 * sigma), (value, sigma, truth)
        assert np.all(err < bound)
    density = obs.column("noise_density")
    truth = np.array([DEMO_TRUTH["gyro_noise_density"]] * 3 + [DEMO_TRUTH["accel_noise_density"]] * 3)
    assert np.all(np.abs(density / truth - 1) < 0.08)
    # the CMKF's PSD per axis: an estimate where identified, else at most its 95 % upper bound (never the prior)
    psd, upper = obs.column("cmkf_psd"), obs.column("cmkf_noise_density_upper")
    assert not np.any(np.isfinite(psd) & np.isfinite(upper))
    assert np.all(psd[np.isfinite(psd)] > 0)
    _, cols, rows = parse_labelled(obs.last["hypotheses"])
    extra = list(HYPOTHESES_EXTRA_COLUMNS)
    assert cols[:2] == ["WN+RW", "WN+GM"] and cols[-len(extra):] == extra
    for row in rows:
        assert row[0] + row[1] == pytest.approx(1.0)
        assert row[cols.index("bank_updates")] > 100
        p_decision = row[cols.index("decision_probability")]
        assert 0.0 <= p_decision <= 1.0 or math.isnan(p_decision)


def test_diagnostics_arrive_about_once_a_second(session):
    obs = session["observer"]
    stamps = [time_of(a) for a in obs.diagnostics if any(s.name.startswith(obs.prefix) for s in a.status)]
    assert len(stamps) >= 5
    statuses = obs.statuses()
    for name in ("IMU input", "Odometry input", "Time stamps", "Stationarity", "Filter consistency",
                 "Filter innovations", "Noise density", "Hypotheses", "Estimate ranges", "Processing"):
        assert name in statuses, name
    assert statuses["Time stamps"][0] == 0
    assert statuses["Noise density"][0] == 0
    assert float(statuses["Processing"][2]["callback_p99_us"]) > 0


def time_of(array: DiagnosticArray) -> float:
    return array.header.stamp.sec + array.header.stamp.nanosec * 1e-9


def _imu(t: float, gyro=(0.0, 0.0, 0.0), accel=(0.0, 0.0, 9.81)) -> Imu:
    msg = Imu()
    msg.header.frame_id = "imu_link"
    msg.header.stamp.sec = math.floor(t)
    msg.header.stamp.nanosec = round((t - math.floor(t)) * 1e9)
    msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z = gyro
    msg.linear_acceleration.x, msg.linear_acceleration.y, msg.linear_acceleration.z = accel
    return msg


def test_nan_and_out_of_order_messages_do_not_stop_the_node(session):
    run, obs, node = session["run"], session["observer"], session["node"]
    pub = obs.node.create_publisher(Imu, "/imu/data", QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE))
    assert obs.spin_until(lambda: pub.get_subscription_count() > 0, 10.0)
    # An anchor just after the bag's last sample, then bad messages whose stamps are off the bag's time grid (a
    # sample of the played bag still in flight on a loaded machine must not be mistaken for one of them).
    anchor = float(run.imu_t[-1]) + 0.02
    bad = [_imu(anchor + 0.0051, gyro=(math.nan, 0.0, 0.0)), _imu(anchor - 0.0123), _imu(anchor),
           _imu(anchor + 0.0101, accel=(math.inf,) * 3)]
    good_stamps = [anchor] + [anchor + 0.02 + 0.005 * k for k in range(5)]
    sent = [_imu(s, gyro=tuple(run.gyro[-1]), accel=tuple(run.accel[-1])) for s in good_stamps]
    sent[1:1] = bad
    # Let the played bag's corrected samples stop arriving first (the check below does not rely on it).
    settled = -1
    while settled != len(obs.corrected):
        settled = len(obs.corrected)
        obs.spin_until(lambda: False, 0.5)
    before = len(obs.corrected)
    for msg in sent:
        pub.publish(msg)
        obs.spin_until(lambda: False, 0.05)
    bag_stamps = {round(s * 1e6) for s in run.imu_t}

    def ours() -> list[float]:
        stamps = [m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in obs.corrected[before:]]
        return [s for s in stamps if round(s * 1e6) not in bag_stamps]

    obs.spin_until(lambda: len(ours()) >= len(good_stamps), 10.0)
    stamps = ours()
    # Only good ones came out, and the node kept working after the bad ones (best effort may lose one or two).
    assert len(stamps) >= 4
    assert all(min(abs(s - g) for g in good_stamps) < 1e-6 for s in stamps), stamps
    assert len({round(s * 1e6) for s in stamps}) == len(stamps), "the duplicate of the anchor came out"
    n_diag = len(obs.diagnostics)
    obs.spin_until(lambda: len(obs.diagnostics) > n_diag + 1, 5.0)
    values = obs.statuses()["IMU input"][2]
    assert int(values["rejected_nonfinite"]) >= 2
    assert int(obs.statuses()["Time stamps"][2]["total_imu_backward"]) >= 1
    assert int(obs.statuses()["Time stamps"][2]["total_imu_duplicate"]) >= 1
    assert node.poll() is None
    obs.node.destroy_publisher(pub)


def _set(obs: Observer, name: str, value) -> tuple[bool, str]:
    client = obs.node.create_client(SetParameters, f"{NODE}/set_parameters")
    assert client.wait_for_service(timeout_sec=10.0)
    if isinstance(value, float):
        pv = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=value)
    else:
        pv = ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=value)
    future = client.call_async(SetParameters.Request(parameters=[Parameter(name=name, value=pv)]))
    assert obs.spin_until(future.done, 10.0)
    result = future.result().results[0]
    obs.node.destroy_client(client)
    return result.successful, result.reason


def test_a_runtime_parameter_change_takes_effect_and_bad_values_are_refused(session):
    obs = session["observer"]
    assert obs.statuses()["Estimate ranges"][0] == 0
    ok, _ = _set(obs, "expected.gyro_bias_max", 1e-4)
    assert ok
    n = len(obs.diagnostics)
    assert obs.spin_until(lambda: len(obs.diagnostics) > n and obs.statuses()["Estimate ranges"][0] == 1, 5.0)
    assert "gyro_y bias" in obs.statuses()["Estimate ranges"][1]
    ok, reason = _set(obs, "stationary.window", -1.0)
    assert not ok and "range" in reason.lower()
    ok, reason = _set(obs, "publish_rate", 5.0)
    assert not ok and reason
    assert session["node"].poll() is None


def test_monitor_once_prints_a_snapshot_of_the_running_node(session, domain_env):
    proc = subprocess.run([sys.executable, "-m", "imu_noise_id", "monitor", "--once", "--timeout", "30"],
                          env=domain_env, capture_output=True, text=True, timeout=90, check=False)
    assert proc.returncode == 0, proc.stderr
    for text in ("gyro_x", "accel_z", "P(WN+RW)", "IMU input", "Noise density"):
        assert text in proc.stdout


def test_the_node_log_holds_no_tracebacks(session):
    text = Path(session["log"]).read_text()
    assert "Traceback" not in text
    assert "not processed" not in text


@pytest.mark.parametrize(("override", "fragment"), [
    ("stationary.window:=-1.0", "stationary.window"),
    ("hypotheses.file:=/nonexistent/hypotheses.yaml", "/nonexistent/hypotheses.yaml"),
])
def test_a_bad_parameter_stops_the_start_with_a_message_naming_it(domain_env, override, fragment):
    proc = subprocess.run([*node_command(NODE_CONFIG), "-p", override], env=domain_env, capture_output=True,
                          text=True, timeout=60, check=False)
    assert proc.returncode == 2
    assert fragment in proc.stderr
    assert "Traceback" not in proc.stderr
