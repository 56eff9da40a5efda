"""``imu_noise_id_node``: the rclpy adapter around :class:`imu_noise_id.pipelines.online.OnlineIdentifier`
(docs/node.md). Inputs: :data:`IMU_INPUT`, :data:`ODOM_INPUT`, :data:`TEMPERATURE_INPUT` (relative names).
Estimation uses the header stamps only; housekeeping timers run on the steady clock.
"""

from __future__ import annotations

import difflib
import math
import sys
import time
from typing import Any

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Vector3Stamped
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Imu, Temperature
from std_msgs.msg import Float64MultiArray

from ..core.axes import AXES
from ..core.errors import InputError
from ..pipelines.online import PARAMETERS, OnlineConfig, OnlineIdentifier
from ..pipelines.online.config import ParamSpec
from ..pipelines.online.watch import ReferenceWatch
from ..report.reference import read_reference
from ..report.spec import noise_density_limits, read_spec
from ..resources import read_hypotheses_file
from .messages import labelled_layout

NODE_NAME = "imu_noise_id_node"
#: The IMU input, relative to the node's namespace (REP-145's name; ``-r imu/data:=imu/data_raw`` for the raw one).
IMU_INPUT = "imu/data"
ODOM_INPUT = "odom"
TEMPERATURE_INPUT = "imu/temperature"
#: The IMU input's name before it was ``imu/data``: a remap of it no longer applies and is warned about.
OLD_IMU_INPUT = "imu"


def _descriptor(spec: ParamSpec) -> ParameterDescriptor:
    unit = f" [{spec.unit}]" if spec.unit else ""
    desc = ParameterDescriptor(
        name=spec.name,
        description=f"{spec.description}{unit}",
        read_only=not spec.runtime,
    )
    if spec.low is not None and type(spec.default) is float:
        desc.floating_point_range = [FloatingPointRange(from_value=float(spec.low), to_value=float(spec.high),
                                                        step=0.0)]
    elif spec.low is not None and type(spec.default) is int:
        desc.integer_range = [IntegerRange(from_value=int(spec.low), to_value=int(spec.high), step=1)]
    return desc


def _sensor_qos(depth: int) -> QoSProfile:
    """Sensor-data QoS (best effort, volatile) with a deep queue: it matches reliable publishers too."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth, reliability=ReliabilityPolicy.BEST_EFFORT)


def _stamp_seconds(stamp: Any) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def imu_orientation(msg: Imu) -> tuple[float, float, float, float] | None:
    """The message's orientation (x, y, z, w), or None where it has none: orientation_covariance[0] = −1 (REP 145)."""
    if msg.orientation_covariance[0] == -1.0:
        return None
    q = msg.orientation
    return (q.x, q.y, q.z, q.w)


class ImuNoiseIdNode(Node):
    """The online identification node (see the module docstring and ``docs/node.md``).

    Raises
    ------
    InputError
        At start-up, when a parameter is out of range or of the wrong type (the message names it).
    """

    def __init__(self, node_name: str = NODE_NAME, **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self._accept_integer_overrides()
        values = {}
        for spec in PARAMETERS:
            try:
                default = list(spec.default) if isinstance(spec.default, tuple) else spec.default
                param = self.declare_parameter(spec.name, default, _descriptor(spec))
            except Exception as exc:  # rclpy raises several types for a bad override
                raise InputError(f"parameter {spec.name}: {exc} (range [{spec.low}, {spec.high}] "
                                 f"{spec.unit})") from None
            values[spec.name] = param.value
        config = OnlineConfig(values)  # InputError names a bad value
        hypotheses = read_hypotheses_file(config.hypotheses_file or None) if config.hypotheses_enabled else None
        self.identifier = OnlineIdentifier(config, hypotheses, self._reference_watch(config))
        self.add_pre_set_parameters_callback(self._integers_as_doubles)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        cfg = self.identifier.config

        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._last_log: dict[str, float] = {}
        self._imu_frame = ""
        self._timings: dict[str, list[float]] | None = (
            {"imu": [], "imu_cpu": [], "odom": [], "publish": []} if cfg.stats_file else None)

        self.pub_accel_bias = self.create_publisher(Vector3Stamped, "~/accel_bias", 10)
        self.pub_gyro_bias = self.create_publisher(Vector3Stamped, "~/gyro_bias", 10)
        self.pub_noise = self.create_publisher(Float64MultiArray, "~/noise", 10)
        self.pub_hypotheses = self.create_publisher(Float64MultiArray, "~/hypotheses", 10)
        self.pub_imu = self.create_publisher(Imu, "~/imu_corrected", cfg.imu_queue_depth)
        self.pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        self.pub_health = (self.create_publisher(DiagnosticArray, "~/health", latched)
                           if self.identifier.watch is not None else None)

        self.create_subscription(Imu, IMU_INPUT, self._on_imu, _sensor_qos(cfg.imu_queue_depth))
        self.create_subscription(Odometry, ODOM_INPUT, self._on_odom, _sensor_qos(cfg.odom_queue_depth))
        self.create_subscription(Temperature, TEMPERATURE_INPUT, self._on_temperature,
                                 _sensor_qos(cfg.odom_queue_depth))

        self._diag_last = time.monotonic()
        self.create_timer(1.0 / cfg.publish_rate, self._publish_estimates, clock=self._steady)
        self.create_timer(cfg.diagnostics_period, self._publish_diagnostics, clock=self._steady)
        self.get_logger().info(
            f"listening on {self.resolve_topic_name(IMU_INPUT)}, {self.resolve_topic_name(ODOM_INPUT)}, "
            f"{self.resolve_topic_name(TEMPERATURE_INPUT)}; publishing under {self.get_fully_qualified_name()}/"
        )
        stale = self.stale_imu_remap()
        if stale:
            self.get_logger().warning(stale)

    def _reference_watch(self, config: OnlineConfig) -> ReferenceWatch | None:
        """The watch against ``reference`` and the noise-density limits of ``spec`` (None when both are empty); an
        unreadable reference or spec is logged and reported on /diagnostics (ERROR), the node runs on."""
        if not config.reference and not config.spec:
            return None
        options = {"ratio": config.watch_ratio, "false_alarms_per_hour": config.watch_false_alarms_per_hour}
        try:
            limits = noise_density_limits(read_spec(config.spec, option="spec")) if config.spec else {}
            ref = read_reference(config.reference) if config.reference else None
        except InputError as exc:
            self.get_logger().error(str(exc))
            return ReferenceWatch(None, math.nan, config.reference, error=str(exc), **options)
        if ref is None:
            return ReferenceWatch(None, math.nan, "", limits=limits, limits_source=config.spec, **options)
        return ReferenceWatch(ref.axes, ref.rate_hz, str(ref.source), limits=limits, limits_source=config.spec,
                              **options)

    def stale_imu_remap(self) -> str:
        """A warning when ``-r imu:=TOPIC`` (the IMU input's old name) remaps to a topic the node does not listen
        on, else ``""``."""
        old = self.resolve_topic_name(OLD_IMU_INPUT)
        listening = self.resolve_topic_name(IMU_INPUT)
        if old == self.resolve_topic_name(OLD_IMU_INPUT, only_expand=True) or old == listening:
            return ""
        return (f"the remap of '{OLD_IMU_INPUT}' to {old} does not apply: the IMU input is '{IMU_INPUT}' "
                f"(listening on {listening}); remap it with -r {IMU_INPUT}:={old}")

    # -- parameters -------------------------------------------------------------------------------------------------
    def _accept_integer_overrides(self) -> None:
        """Integer overrides of floating-point parameters become doubles (``-p publish_rate:=20`` means 20.0);
        overrides that name no parameter of this node are warned about (docs/node.md, "Why …")."""
        floats = {spec.name for spec in PARAMETERS if type(spec.default) is float}
        known = {spec.name for spec in PARAMETERS} | {"use_sim_time"}
        overrides = self._parameter_overrides  # rclpy keeps the --ros-args / params-file values here
        for name, param in list(overrides.items()):
            if name in floats and param.type_ == Parameter.Type.INTEGER:
                overrides[name] = Parameter(name, Parameter.Type.DOUBLE, float(param.value))
            elif name not in known:
                close = difflib.get_close_matches(name, sorted(known), n=1)
                self.get_logger().warning(f"unknown parameter {name!r} ignored" +
                                          (f": did you mean {close[0]!r}?" if close else ""))

    @staticmethod
    def _integers_as_doubles(params: list[Parameter]) -> list[Parameter]:
        """Integers set at runtime for floating-point parameters as doubles (``gap_factor 12`` means 12.0)."""
        floats = {spec.name for spec in PARAMETERS if type(spec.default) is float}
        return [Parameter(p.name, Parameter.Type.DOUBLE, float(p.value))
                if p.name in floats and p.type_ == Parameter.Type.INTEGER else p for p in params]

    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        changes = {p.name: p.value for p in params if p.name in {s.name for s in PARAMETERS}}
        if not changes:
            return SetParametersResult(successful=True)
        try:
            config = self.identifier.config.updated(changes)
        except InputError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        self.identifier.set_config(config)
        self.get_logger().info("parameters changed: " + ", ".join(f"{k}={v!r}" for k, v in changes.items()))
        return SetParametersResult(successful=True)

    # -- inputs -----------------------------------------------------------------------------------------------------
    def _on_imu(self, msg: Imu) -> None:
        start = time.perf_counter()
        cpu_start = time.thread_time() if self._timings is not None else 0.0
        try:
            w = msg.angular_velocity
            a = msg.linear_acceleration
            frame = msg.header.frame_id
            released = self.identifier.process_imu(
                _stamp_seconds(msg.header.stamp), (w.x, w.y, w.z), (a.x, a.y, a.z), frame, time.monotonic(),
                orientation_xyzw=imu_orientation(msg), source=msg)
            self._imu_frame = frame
            for out in released:  # usually this message; a held one first after a jump in the stamps
                corrected = out.source
                corrected.angular_velocity.x, corrected.angular_velocity.y, corrected.angular_velocity.z = out.gyro
                (corrected.linear_acceleration.x, corrected.linear_acceleration.y,
                 corrected.linear_acceleration.z) = out.accel
                if out.gyro_variance is not None:
                    corrected.angular_velocity_covariance = _diag9(out.gyro_variance)
                    corrected.linear_acceleration_covariance = _diag9(out.accel_variance)
                self._send(self.pub_imu, corrected)
        except Exception as exc:  # never die on input: report and continue
            self._log("imu_exception", f"IMU message not processed: {type(exc).__name__}: {exc}")
        finally:
            elapsed = time.perf_counter() - start
            self.identifier.processing_time.add(elapsed)
            if self._timings is not None:
                self._timings["imu"].append(elapsed)
                self._timings["imu_cpu"].append(time.thread_time() - cpu_start)
        self._flush_events()

    def _on_odom(self, msg: Odometry) -> None:
        start = time.perf_counter()
        try:
            v = msg.twist.twist.linear
            w = msg.twist.twist.angular
            p = msg.pose.pose.position
            q = msg.pose.pose.orientation
            self.identifier.process_odometry(
                _stamp_seconds(msg.header.stamp), (v.x, v.y, v.z), (w.x, w.y, w.z), msg.child_frame_id,
                time.monotonic(), position=(p.x, p.y, p.z), orientation_xyzw=(q.x, q.y, q.z, q.w),
                pose_covariance=msg.pose.covariance, twist_covariance=msg.twist.covariance,
            )
        except Exception as exc:
            self._log("odom_exception", f"odometry message not processed: {type(exc).__name__}: {exc}")
        if self._timings is not None:
            self._timings["odom"].append(time.perf_counter() - start)
        self._flush_events()

    def _on_temperature(self, msg: Temperature) -> None:
        try:
            self.identifier.process_temperature(_stamp_seconds(msg.header.stamp), msg.temperature,
                                                msg.header.frame_id, time.monotonic())
        except Exception as exc:
            self._log("temperature_exception", f"temperature message not processed: {type(exc).__name__}: {exc}")
        self._flush_events()

    # -- logging ----------------------------------------------------------------------------------------------------
    def _flush_events(self) -> None:
        for key, text in self.identifier.pop_events():
            self._log(key, text)

    def _log(self, key: str, text: str) -> None:
        """Warn, at most once per ``log_throttle`` seconds per kind of problem."""
        now = time.monotonic()
        last = self._last_log.get(key)
        if last is not None and now - last < self.identifier.config.log_throttle:
            return
        self._last_log[key] = now
        self.get_logger().warning(text)

    # -- outputs ----------------------------------------------------------------------------------------------------
    def _header_stamp(self, t: float) -> Any:
        from builtin_interfaces.msg import Time

        if not math.isfinite(t):
            return self.get_clock().now().to_msg()
        sec = math.floor(t)
        return Time(sec=int(sec), nanosec=min(round((t - sec) * 1e9), 999_999_999))

    def write_stats(self) -> None:
        """Write the callback-time percentiles to ``stats_file`` (when set)."""
        if self._timings is None:
            return
        import json

        summary = {}
        for key, values in self._timings.items():
            arr = np.array(values) * 1e6
            summary[key] = {"count": int(arr.size)} | ({
                "p50_us": float(np.percentile(arr, 50)), "p90_us": float(np.percentile(arr, 90)),
                "p99_us": float(np.percentile(arr, 99)), "p99.9_us": float(np.percentile(arr, 99.9)),
                "max_us": float(arr.max())} if arr.size else {})
        summary["imu_received"] = self.identifier.imu.stats.received
        summary["odom_received"] = self.identifier.odom.stats.received
        with open(self.identifier.config.stats_file, "w") as f:
            json.dump(summary, f, indent=1)

    def _send(self, publisher: Publisher, msg: Any) -> None:
        """Publish ``msg``; once the context is shut down (Ctrl-C during a callback), quietly not (docs/node.md,
        "Why …")."""
        try:
            publisher.publish(msg)
        except RuntimeError:  # rclpy's RCLError: "publisher's context is invalid"
            if self.context.ok():
                raise

    def _publish_estimates(self) -> None:
        start = time.perf_counter()
        self._publish_estimates_now()
        if self._timings is not None:
            self._timings["publish"].append(time.perf_counter() - start)

    def _publish_estimates_now(self) -> None:
        try:
            self.identifier.update_identification()
        except Exception as exc:  # a failing bank must not stop the biases and the corrected IMU
            self._log("bank_exception", f"hypothesis bank update failed: {type(exc).__name__}: {exc}")
        est = self.identifier.estimates()
        if not math.isfinite(est.t):
            return
        stamp = self._header_stamp(est.t)
        for pub, vec in ((self.pub_gyro_bias, est.gyro_bias), (self.pub_accel_bias, est.accel_bias)):
            msg = Vector3Stamped()
            msg.header.stamp = stamp
            msg.header.frame_id = self._imu_frame
            msg.vector.x, msg.vector.y, msg.vector.z = (float(v) for v in vec)
            self._send(pub, msg)
        columns, table = est.noise_table()
        noise = Float64MultiArray()
        labelled_layout(noise, "axis", AXES, "field", columns)
        noise.data = table.ravel().tolist()
        self._send(self.pub_noise, noise)
        report = self.identifier.hypotheses()
        if report is not None:
            columns, table = report.table()
            hyp = Float64MultiArray()
            labelled_layout(hyp, "axis", AXES, "hypothesis", columns)
            hyp.data = table.ravel().tolist()
            self._send(self.pub_hypotheses, hyp)

    def _publish_diagnostics(self) -> None:
        now = time.monotonic()
        window = now - self._diag_last
        self._diag_last = now
        self._flush_events()
        statuses = self.identifier.diagnostics(now, window)
        array = DiagnosticArray()
        stamp = self.get_clock().now()
        array.header.stamp = (stamp.to_msg() if stamp.nanoseconds > 0
                              else self._header_stamp(self.identifier.last_imu_t))
        name = self.get_fully_qualified_name().lstrip("/")
        for s in statuses:
            array.status.append(DiagnosticStatus(
                level=bytes([s.level]), name=f"{name}: {s.name}", message=s.message,
                hardware_id=self._imu_frame,
                values=[KeyValue(key=k, value=v) for k, v in s.values.items()],
            ))
        self._send(self.pub_diag, array)
        if self.pub_health is not None:
            health = DiagnosticArray(header=array.header)
            health.status = [s for s in array.status if s.name.endswith(("(gyro)", "(accel)"))]
            self._send(self.pub_health, health)


def _diag9(variance: tuple[float, float, float]) -> np.ndarray:
    cov = np.zeros(9)
    cov[0], cov[4], cov[8] = variance
    return cov


def _usage() -> str:
    lines = [
        f"usage: {NODE_NAME} [--ros-args --params-file FILE -p NAME:=VALUE -r {IMU_INPUT}:=TOPIC ...]",
        "",
        f"Online IMU error identification: subscribes to {IMU_INPUT} (sensor_msgs/Imu), {ODOM_INPUT} "
        "(nav_msgs/Odometry) and",
        f"{TEMPERATURE_INPUT} (sensor_msgs/Temperature); publishes ~/accel_bias, ~/gyro_bias, ~/noise, ~/hypotheses,",
        "~/imu_corrected and /diagnostics. Defaults: share/imu_noise_id/config/imu_noise_id.yaml; docs/node.md.",
        "",
        "parameters (name = default [range] unit):",
    ]
    for p in PARAMETERS:
        rng = f"[{p.low:g}, {p.high:g}]" if p.low is not None else ""
        when = "" if p.runtime else " (start-up only)"
        lines.append(f"  {p.name} = {p.default!r} {rng} {p.unit}{when}".rstrip())
        lines.append(f"      {p.description}")
    return "\n".join(lines)


def _executor(kind: str) -> Any:
    """The EventsExecutor when asked for and available, else the SingleThreadedExecutor."""
    if kind == "events":
        try:
            from rclpy.experimental import EventsExecutor

            return EventsExecutor()
        except ImportError:  # pragma: no cover - older rclpy
            pass
    from rclpy.executors import SingleThreadedExecutor

    return SingleThreadedExecutor()


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``imu_noise_id_node`` (``python -m imu_noise_id.ros.node``): spin until interrupted."""
    args = list(sys.argv if argv is None else argv)
    user_args = args[1:args.index("--ros-args")] if "--ros-args" in args else args[1:]
    if "-h" in user_args or "--help" in user_args:
        print(_usage())
        return 0
    try:
        rclpy.init(args=args)
    except RuntimeError as exc:  # rclpy's RCLError: a missing or malformed --params-file, a bad --ros-args
        reason = str(exc).split(", at ")[0].removeprefix("failed to initialize rcl: ").strip()
        print(f"{NODE_NAME}: error: {reason}. Check the --ros-args (a --params-file must exist and be ROS 2 "
              "parameter YAML: node_name: ros__parameters: {…})", file=sys.stderr)
        return 2
    try:
        try:
            node = ImuNoiseIdNode()
        except InputError as exc:
            print(f"{NODE_NAME}: error: {exc}", file=sys.stderr)
            return 2
        executor = _executor(node.identifier.config.executor)
        executor.add_node(node)
        try:
            # spin_once in a loop: EventsExecutor.spin() of rclpy 7.1 neither fires timers nor returns on SIGTERM.
            while rclpy.ok():
                executor.spin_once(timeout_sec=0.1)
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
        finally:
            node.write_stats()
            node.destroy_node()
    finally:
        if rclpy.ok():
            rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
