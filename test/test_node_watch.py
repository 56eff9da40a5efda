"""The node watching its IMU against a reference analysis, over real DDS on loopback: the per-sensor statuses on
/diagnostics, the latched ~/health topic a late subscriber still gets, and an unreadable reference reported, not
fatal."""

from __future__ import annotations

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")

from dds import domain_id  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402
from sensor_msgs.msg import Imu  # noqa: E402

from imu_noise_id.core.axes import AXES, GYRO_AXES  # noqa: E402
from imu_noise_id.core.noise.components import RW, WN  # noqa: E402
from imu_noise_id.core.simulation.static import simulate_static_imu  # noqa: E402
from imu_noise_id.pipelines.analyze import AnalyzeOptions, ModelStage, analyze  # noqa: E402
from imu_noise_id.report.analysis import write_analysis  # noqa: E402

pytestmark = pytest.mark.ros
MODEL = {a: [WN(1.7e-4), RW(2e-5)] if a in GYRO_AXES else [WN(2e-3), RW(3e-4)] for a in AXES}


@pytest.fixture(scope="module")
def reference_dir(tmp_path_factory):
    imu = simulate_static_imu(MODEL, 100.0, 300.0, seed=61)
    result = analyze(imu, options=AnalyzeOptions(kinds=("allan",), models=ModelStage("WN+RW"), loop=False, jobs=1))
    out = tmp_path_factory.mktemp("reference")
    write_analysis(result, out, meta={})
    return out


def _run(reference: str, monkeypatch, ros_env, seconds: float = 70.0,
         spec: str = "") -> tuple[list[DiagnosticArray], list]:
    """The node in this process with ``reference`` and ``spec``, fed ``seconds`` of a standing IMU at 100 Hz (gyro_z's
    noise ×2 over the second half: 35 s of it, beyond the alarm and the 1000 pairs, 20 s at 100 Hz, that confirm it);
    the /diagnostics arrays it published and what a late ~/health subscriber got."""
    from imu_noise_id.ros.node import ImuNoiseIdNode

    for key, value in {**ros_env, "ROS_DOMAIN_ID": str(domain_id(10, 99))}.items():
        monkeypatch.setenv(key, value)
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=int(domain_id(10, 99)))
    executor = SingleThreadedExecutor(context=context)
    try:
        node = ImuNoiseIdNode(context=context, parameter_overrides=[
            Parameter("reference", Parameter.Type.STRING, reference),
            Parameter("spec", Parameter.Type.STRING, spec),
            Parameter("diagnostics_period", Parameter.Type.DOUBLE, 0.2),
            Parameter("hypotheses.enabled", Parameter.Type.BOOL, False)])
        peer = rclpy.create_node("watch_test_peer", context=context)
        diagnostics: list[DiagnosticArray] = []
        peer.create_subscription(DiagnosticArray, "/diagnostics", diagnostics.append, 50)
        pub = peer.create_publisher(Imu, "/imu/data", QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE))
        executor.add_node(node)
        executor.add_node(peer)
        for _ in range(20):
            executor.spin_once(timeout_sec=0.05)
        rng = np.random.default_rng(5)
        n = int(seconds * 100)
        for k in range(n):
            sigma = np.array([1.7e-4] * 3 + [2e-3] * 3) * 10.0
            if k >= n // 2:
                sigma[2] *= 2.0
            y = rng.standard_normal(6) * sigma + np.array([0.0, 0.0, 0.0, 0.0, 0.0, 9.81])
            msg = Imu()
            t = 50.0 + k * 0.01
            msg.header.stamp.sec, msg.header.stamp.nanosec = int(t), round((t % 1) * 1e9)
            msg.header.frame_id = "imu"
            msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z = y[:3]
            msg.linear_acceleration.x, msg.linear_acceleration.y, msg.linear_acceleration.z = y[3:]
            msg.orientation_covariance[0] = -1.0
            pub.publish(msg)
            for _ in range(200):  # each message handled before the next: a loaded machine drops none
                if node.identifier.imu.stats.received > k:
                    break
                executor.spin_once(timeout_sec=0.01)
        for _ in range(40):
            executor.spin_once(timeout_sec=0.05)
        health: list = []
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        peer.create_subscription(DiagnosticArray, "/imu_noise_id_node/health", health.append, latched)
        for _ in range(40):
            executor.spin_once(timeout_sec=0.05)
            if health:
                break
        node.destroy_node()
        peer.destroy_node()
        return diagnostics, health
    finally:
        executor.shutdown()
        rclpy.shutdown(context=context)


def _latest(arrays: list[DiagnosticArray]) -> dict[str, tuple[int, str]]:
    out = {}
    for array in arrays:
        for s in array.status:
            out[s.name.split(": ", 1)[1]] = (s.level[0], s.message)
    return out


def test_the_node_flags_a_noisier_gyro_against_its_reference(reference_dir, monkeypatch, ros_env):
    diagnostics, health = _run(str(reference_dir), monkeypatch, ros_env)
    statuses = _latest(diagnostics)
    level, message = statuses["Reference watch (gyro)"]
    assert level == 1 and "gyro_z noise up" in message, message  # WARN
    assert statuses["Reference watch (accel)"][0] == 0, statuses["Reference watch (accel)"]
    assert health, "a late subscriber got no ~/health (latched)"
    names = {s.name.split(": ", 1)[1] for s in health[-1].status}
    assert names == {"Reference watch (gyro)", "Reference watch (accel)"}


def test_an_unreadable_reference_is_reported_and_the_node_runs_on(tmp_path, monkeypatch, ros_env):
    diagnostics, _ = _run(str(tmp_path / "nowhere"), monkeypatch, ros_env, seconds=3.0)
    level, message = _latest(diagnostics)["Reference watch (gyro)"]
    assert level == 2 and "nowhere does not exist" in message


def test_the_node_errs_when_a_gyro_is_beyond_its_datasheet_limit(reference_dir, tmp_path, monkeypatch, ros_env):
    """With a gyro noise-density limit of 2.5e-4 (the reference's 1.7e-4 is within it), gyro_z at twice its reference
    is beyond it: the gyro's status is ERROR, naming the axis; the accelerometer, without a limit, is not."""
    spec = tmp_path / "spec.yaml"
    spec.write_text("gyro: {noise_density: 2.5e-4}\n")
    diagnostics, _ = _run(str(reference_dir), monkeypatch, ros_env, spec=str(spec))
    statuses = _latest(diagnostics)
    level, message = statuses["Reference watch (gyro)"]
    assert level == 2 and "gyro_z noise beyond the spec" in message, message  # ERROR
    assert statuses["Reference watch (accel)"][0] == 0, statuses["Reference watch (accel)"]

