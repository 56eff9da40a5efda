"""Parameters of ``imu_noise_id_node`` (names, defaults, ranges, units, validation): :data:`PARAMETERS` is the single
source; the CMKF's tunables, in :data:`CMKF_TUNABLES`, take type and default from ``CmkfConfig`` fields and make the
``cmkf.*`` and ``nis.window`` parameters and the ``imu-noise-id cmkf`` options; :func:`tuned_config` makes the
``CmkfConfig`` of either (:func:`cmkf_config` the node's)."""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

from ...core.cmkf.config import GRAVITY_SOURCES, MEASUREMENTS, CmkfConfig
from ...core.errors import InputError

#: The CMKF's defaults and field types (the ``cmkf.*`` and ``nis.window`` parameters take theirs from here).
_CMKF = CmkfConfig()
_CMKF_TYPES = typing.get_type_hints(CmkfConfig)


@dataclass(frozen=True)
class ParamSpec:
    """One tunable: ROS parameter name, default, closed range, unit and whether it may change at runtime."""

    name: str
    default: float | int | bool | str
    description: str
    unit: str = ""
    low: float | None = None
    high: float | None = None
    runtime: bool = True
    choices: tuple[str, ...] = ()

    @property
    def attr(self) -> str:
        """Attribute name in :class:`OnlineConfig` (dots become underscores)."""
        return self.name.replace(".", "_")

    def check(self, value: Any) -> str | None:  # noqa: PLR0911 - one early return per kind of mistake
        """The reason ``value`` is not acceptable, or None when it is."""
        kind = type(self.default)
        if kind is bool:
            if not isinstance(value, bool):
                return f"{self.name} must be true or false, got {value!r}"
            return None
        if kind is str:
            if not isinstance(value, str):
                return f"{self.name} must be a string, got {value!r}"
            if self.choices and value not in self.choices:
                return f"{self.name} must be one of {', '.join(self.choices)}, got {value!r}"
            return None
        if kind is tuple:
            values = list(value) if isinstance(value, (list, tuple)) or hasattr(value, "tolist") else None
            if (values is None or len(values) != len(self.default)
                    or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in values)):
                return f"{self.name} must be {len(self.default)} finite numbers, got {value!r}"
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return f"{self.name} must be a number, got {value!r}"
        if kind is int and not float(value).is_integer():
            return f"{self.name} must be an integer, got {value!r}"
        if not math.isfinite(float(value)):
            return f"{self.name} must be finite, got {value!r}"
        if (self.low is not None and value < self.low) or (self.high is not None and value > self.high):
            return f"{self.name} = {value!r} is outside its range [{self.low}, {self.high}] {self.unit}".rstrip()
        return None


@dataclass(frozen=True)
class CmkfTunable:
    """One :class:`CmkfConfig` field a user may set: its description, unit, range and choices; where it is set (a
    node parameter, an option of ``imu-noise-id cmkf``). Its type and default are the field's."""

    field: str
    description: str
    unit: str = ""
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] = ()
    #: The node parameter's name ("": ``cmkf.<field>``; None: not a node parameter).
    parameter: str | None = ""
    #: An option ``--<field with dashes>`` of ``imu-noise-id cmkf``.
    option: bool = False
    runtime: bool = False
    #: The node's default where it is not the field's (an optional field's None is the node's 0.0 anyway).
    node_default: float | None = None

    @property
    def kind(self) -> type:
        """The field's type without None (float, int, str or tuple)."""
        hint = _CMKF_TYPES[self.field]
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        base = args[0] if isinstance(hint, types.UnionType) else hint
        return typing.get_origin(base) or base

    @property
    def optional(self) -> bool:
        """The field takes None (the node's 0)."""
        return type(None) in typing.get_args(_CMKF_TYPES[self.field])

    @property
    def default(self) -> Any:
        """The field's default in :class:`CmkfConfig` (None for an optional field left unset)."""
        return getattr(_CMKF, self.field)

    @property
    def name(self) -> str:
        return self.parameter or f"cmkf.{self.field}"

    def spec(self) -> ParamSpec:
        """The node parameter (an optional field's None is 0.0: "from the messages")."""
        default = self.node_default if self.node_default is not None else self.default
        default = self.kind(0 if default is None else default)
        return ParamSpec(self.name, default, self.description, self.unit, self.low, self.high, self.runtime,
                         self.choices)

    def value(self, value: Any) -> Any:
        """The field's value from a parameter or option value (0 or None of an optional field: None)."""
        if self.optional and not value:
            return None
        return tuple(float(v) for v in value) if self.kind is tuple else value


#: The CMKF's tunables (the node's parameters in this order).
CMKF_TUNABLES: tuple[CmkfTunable, ...] = (
    CmkfTunable("nis_window", "number of filter updates in the normalised-innovation-squared window", "updates", 10,
                100000, parameter="nis.window", runtime=True),
    CmkfTunable("imu_rotation_xyzw", "orientation of the IMU frame in the base frame (child_frame_id of the "
                "odometry), quaternion x y z w"),
    CmkfTunable("measurement", "odometry used by the CMKF: twist (body velocity, right for wheel odometry) or "
                "pose_twist (position and velocity, paper 004 eq. 8)", choices=MEASUREMENTS, option=True),
    CmkfTunable("gravity_source", "orientation for gravity compensation: odometry (its orientation, propagated with "
                "the gyro) or imu (the Imu message's orientation)", choices=GRAVITY_SOURCES),
    CmkfTunable("accel_bias_tau", "correlation time of the accelerometer bias (paper 004 eq. 3)", "s", 1.0, 1e7,
                option=True),
    CmkfTunable("accel_bias_sigma", "steady-state standard deviation of the accelerometer bias", "m/s^2", 1e-6,
                100.0, option=True),
    CmkfTunable("s_v0", "initial velocity-random-walk PSD S_v", "m^2/s^3", 1e-12, 10.0, option=True),
    CmkfTunable("gyro_bias_tau", "correlation time of the gyro bias", "s", 1.0, 1e7, option=True),
    CmkfTunable("gyro_bias_sigma", "steady-state standard deviation of the gyro bias", "rad/s", 1e-7, 10.0,
                option=True),
    CmkfTunable("s_g0", "initial angle-random-walk PSD S_g", "rad^2/s", 1e-14, 1.0),
    CmkfTunable("velocity_noise_std", "odometry velocity noise; 0: from the message twist covariance "
                f"({_CMKF.default_velocity_noise_std:g} m/s when it is unknown)", "m/s", 0.0, 100.0, option=True),
    CmkfTunable("position_noise_std", "odometry position noise (pose_twist); 0: from the message pose covariance "
                f"({_CMKF.default_position_noise_std:g} m when it is unknown)", "m", 0.0, 100.0, parameter=None,
                option=True),
    CmkfTunable("angular_velocity_noise_std", "odometry angular-velocity noise; 0: from the message covariance "
                f"({_CMKF.default_angular_velocity_noise_std:g} rad/s when it is unknown)", "rad/s", 0.0, 100.0,
                option=True),
    # the node's own default: a ROS graph's two topics differ by more than the core's 0.05 s
    CmkfTunable("late_odom_tolerance", "IMU samples wait this long before the CMKF so that odometry up to this much "
                "later (in header time) is still processed in stamp order", "s", 0.0, 5.0,
                parameter="cmkf.input_latency", runtime=True, node_default=0.1),
    CmkfTunable("max_odom_gap", "an odometry gap longer than this restarts the S_v estimator chain", "s", 0.01,
                3600.0),
    CmkfTunable("max_imu_gap", "an IMU gap longer than this re-initialises position and velocity", "s", 0.001,
                3600.0),
)
_CMKF_SPECS = {t.name: t.spec() for t in CMKF_TUNABLES if t.parameter is not None}


PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("stationary.max_linear_speed", 0.05, "odometry |linear twist| below which the base is still",
              "m/s", 0.0, 10.0),
    ParamSpec("stationary.max_angular_speed", 0.05, "odometry |angular twist| below which the base is still",
              "rad/s", 0.0, 10.0),
    ParamSpec("stationary.max_gyro_rate", 0.05, "|mean angular rate − gyro bias| below which the IMU is still",
              "rad/s", 0.0, 10.0),
    ParamSpec("stationary.max_gyro_std", 0.05, "per-axis angular-rate standard deviation (over "
              "stationary.window) below which the IMU is still", "rad/s", 0.0, 10.0),
    ParamSpec("stationary.max_accel_std", 0.3, "per-axis specific-force standard deviation (over "
              "stationary.window) below which the IMU is still", "m/s^2", 0.0, 100.0),
    ParamSpec("stationary.window", 0.5, "time constant of the exponentially weighted IMU statistics", "s",
              0.01, 60.0),
    ParamSpec("stationary.enter_delay", 1.0, "hysteresis: the evidence must say 'still' this long before the "
              "platform counts as stationary", "s", 0.0, 600.0),
    ParamSpec("stationary.guard", 0.5, "stationary samples wait this long before the noise identification "
              "uses them; they are dropped if motion starts meanwhile", "s", 0.0, 60.0),
    ParamSpec("stationary.require_odometry", False, "true: never stationary without fresh odometry; false: "
              "decide from the IMU statistics alone when odometry is absent"),
    ParamSpec("odom_timeout", 0.5, "odometry older than this (header stamps, against the IMU stamp) counts "
              "as absent", "s", 0.01, 60.0),
    ParamSpec("gap_factor", 10.0, "a period longer than gap_factor × the nominal IMU period is a gap", "",
              1.5, 1000.0),
    ParamSpec("backward_reset_count", 10, "this many consecutive stamps behind the last accepted one, following "
              "one another at about the stream's rate, are a restarted source: a new time line (what was "
              "identified is kept)", "messages", 2, 100000),
    ParamSpec("stale_timeout", 2.0, "no message for this long (steady clock) makes an input STALE", "s",
              0.1, 3600.0),
    ParamSpec("expected_imu_rate", 0.0, "IMU rate expected [Hz]; a received rate below 80 % of it is a "
              "warning (0: not checked)", "Hz", 0.0, 100000.0),
    ParamSpec("expected_odom_rate", 0.0, "odometry rate expected; a received rate below 80 % of it is a "
              "warning (0: not checked)", "Hz", 0.0, 100000.0),
    ParamSpec("imu_range.gyro", 0.0, "full scale of the gyro (datasheet range): samples at it are flagged as "
              "saturated (0: unknown; then a value repeated at the largest magnitude seen, above 2 rad/s, is)",
              "rad/s", 0.0, 1000.0),
    ParamSpec("imu_range.accel", 0.0, "full scale of the accelerometer: samples at it are flagged as saturated (0: "
              "unknown; then a value repeated at the largest magnitude seen, above 19 m/s^2, is)", "m/s^2", 0.0,
              10000.0),
    ParamSpec("expected.gyro_bias_max", 0.1, "|gyro bias| above this on any axis is reported", "rad/s",
              0.0, 100.0),
    ParamSpec("expected.accel_bias_max", 0.5, "|accelerometer bias| above this on any axis is reported",
              "m/s^2", 0.0, 100.0),
    ParamSpec("expected.gyro_noise_density_max", 0.01, "gyro noise density above this is reported",
              "rad/s/sqrt(Hz)", 0.0, 100.0),
    ParamSpec("expected.accel_noise_density_max", 0.1, "accelerometer noise density above this is reported",
              "m/s^2/sqrt(Hz)", 0.0, 1000.0),
    ParamSpec("noise.min_samples", 200, "stationary samples needed before a noise density is published and "
              "used for the corrected IMU covariance", "samples", 10, 10000000),
    _CMKF_SPECS["nis.window"],
    ParamSpec("innovations.window", 500, "filter updates in the whiteness and consistency tests of the CMKF's "
              "and the gyro filter's innovations (per axis)", "updates", 50, 100000, runtime=False),
    ParamSpec("innovations.lags", 10, "Ljung-Box lags of the innovation whiteness test (less than a quarter of "
              "innovations.window)", "lags", 1, 1000, runtime=False),
    ParamSpec("innovations.alpha", 1e-4, "level of each innovation test (they run every diagnostics period: keep "
              "it small)", "", 1e-9, 0.1, runtime=False),
    ParamSpec("publish_rate", 10.0, "rate of ~/accel_bias, ~/gyro_bias, ~/noise and ~/hypotheses (steady "
              "clock)", "Hz", 0.1, 1000.0, runtime=False),
    ParamSpec("diagnostics_period", 1.0, "period of /diagnostics (steady clock)", "s", 0.05, 60.0,
              runtime=False),
    ParamSpec("log_throttle", 5.0, "minimum time between two log lines about the same input problem", "s",
              0.0, 3600.0),
    *(spec for name, spec in _CMKF_SPECS.items() if name.startswith("cmkf.")),
    ParamSpec("hypotheses.enabled", True, "run the Bayesian hypothesis bank on stationary samples",
              runtime=False),
    ParamSpec("hypotheses.file", "", "hypothesis-set YAML (empty: the packaged config/hypotheses_default.yaml)",
              runtime=False),
    ParamSpec("hypotheses.bank_rate", 10.0, "rate of the bank's samples: the IMU samples are block-averaged to "
              "it (exact averaged models)", "Hz", 0.01, 1000.0, runtime=False),
    ParamSpec("reference", "", "results folder (or its imu.yaml) of an analyze of this IMU: while stationary, each "
              "axis's noise density is watched against it (empty: no watch)", runtime=False),
    ParamSpec("spec", "", "datasheet limits, YAML as batch --spec reads ({gyro: {noise_density: …}, accel: {…}}, SI): "
              "while stationary, an axis whose noise density is beyond its sensor's noise_density limit turns the "
              "sensor's watch status ERROR (with a reference its model's shape, else white noise; empty: none)",
              runtime=False),
    ParamSpec("watch.ratio", 1.5, "noise-density ratio (live/reference, either way) the reference watch is tuned to",
              "", 1.01, 100.0, runtime=False),
    ParamSpec("watch.false_alarms_per_hour", 0.1, "false alarms per hour of stationary data the reference watch "
              "allows the whole IMU (shared among its six axes and their tests)", "1/h", 1e-9, 3600.0, runtime=False),
    ParamSpec("executor", "events", "rclpy executor: events (rclpy.experimental.EventsExecutor, about twice the "
              "message throughput) or single_threaded", runtime=False, choices=("events", "single_threaded")),
    ParamSpec("stats_file", "", "when set, every callback's processing time is kept and a JSON summary "
              "(percentiles) is written to this file at shutdown (for bench/bench_node.py)", runtime=False),
    ParamSpec("imu_queue_depth", 1000, "subscription queue depth of the IMU topic (sensor-data QoS)",
              "messages", 100, 100000, runtime=False),
    ParamSpec("odom_queue_depth", 1000, "subscription queue depth of the odometry and temperature topics",
              "messages", 1, 100000, runtime=False),
)

PARAMETER_BY_NAME: dict[str, ParamSpec] = {p.name: p for p in PARAMETERS}


def _validated(values: dict[str, Any]) -> dict[str, Any]:
    """Every parameter's value: ``values`` over the defaults, checked (InputError naming the first bad one), ints of
    float parameters as floats, tuples of floats."""
    merged = {p.name: p.default for p in PARAMETERS}
    unknown = sorted(set(values) - set(merged))
    if unknown:
        raise InputError(f"unknown parameter(s) {', '.join(unknown)}; known: {', '.join(sorted(merged))}")
    merged.update(values)
    for name, value in merged.items():
        spec = PARAMETER_BY_NAME[name]
        if type(spec.default) is float and isinstance(value, int) and not isinstance(value, bool):
            merged[name] = float(value)
        reason = spec.check(merged[name])
        if reason:
            raise InputError(f"parameter {reason}")
        if type(spec.default) is tuple:
            merged[name] = tuple(float(v) for v in merged[name])
    return merged


@dataclass(frozen=True, init=False)
class OnlineConfig:
    """Validated values, one field per parameter of :data:`PARAMETERS` (dots → ``_``); ``OnlineConfig(values)``: by
    name over the defaults; InputError for an unknown name or an invalid value."""

    stationary_max_linear_speed: float
    stationary_max_angular_speed: float
    stationary_max_gyro_rate: float
    stationary_max_gyro_std: float
    stationary_max_accel_std: float
    stationary_window: float
    stationary_enter_delay: float
    stationary_guard: float
    stationary_require_odometry: bool
    odom_timeout: float
    gap_factor: float
    backward_reset_count: int
    stale_timeout: float
    expected_imu_rate: float
    expected_odom_rate: float
    imu_range_gyro: float
    imu_range_accel: float
    expected_gyro_bias_max: float
    expected_accel_bias_max: float
    expected_gyro_noise_density_max: float
    expected_accel_noise_density_max: float
    noise_min_samples: int
    nis_window: int
    innovations_window: int
    innovations_lags: int
    innovations_alpha: float
    publish_rate: float
    diagnostics_period: float
    log_throttle: float
    cmkf_imu_rotation_xyzw: tuple[float, ...]
    cmkf_measurement: str
    cmkf_gravity_source: str
    cmkf_accel_bias_tau: float
    cmkf_accel_bias_sigma: float
    cmkf_s_v0: float
    cmkf_gyro_bias_tau: float
    cmkf_gyro_bias_sigma: float
    cmkf_s_g0: float
    cmkf_velocity_noise_std: float
    cmkf_angular_velocity_noise_std: float
    cmkf_input_latency: float
    cmkf_max_odom_gap: float
    cmkf_max_imu_gap: float
    hypotheses_enabled: bool
    hypotheses_file: str
    hypotheses_bank_rate: float
    reference: str
    spec: str
    watch_ratio: float
    watch_false_alarms_per_hour: float
    executor: str
    stats_file: str
    imu_queue_depth: int
    odom_queue_depth: int

    def __init__(self, values: dict[str, Any] | None = None) -> None:
        for name, value in _validated(dict(values or {})).items():
            object.__setattr__(self, PARAMETER_BY_NAME[name].attr, value)  # a frozen dataclass's own way

    @property
    def values(self) -> dict[str, Any]:
        """Every parameter's value by parameter name."""
        return {p.name: getattr(self, p.attr) for p in PARAMETERS}

    def updated(self, changes: dict[str, Any]) -> OnlineConfig:
        """A new configuration with ``changes`` applied; InputError for an unknown name, an invalid value or a
        parameter that cannot change at runtime."""
        for name in changes:
            spec = PARAMETER_BY_NAME.get(name)
            if spec is not None and not spec.runtime:
                raise InputError(f"parameter {name} cannot change at runtime: restart the node to change it")
        return OnlineConfig({**self.values, **changes})


if [f.name for f in dataclasses.fields(OnlineConfig)] != [p.attr for p in PARAMETERS]:
    raise ImportError("OnlineConfig's fields must be PARAMETERS' attribute names, in their order")


def tuned_config(tunables: Iterable[CmkfTunable], value: Callable[[CmkfTunable], Any], what: str,
                 **fields: Any) -> CmkfConfig:
    """A validated :class:`CmkfConfig`: each tunable's field from ``value(tunable)`` (a parameter's or option's value,
    :meth:`CmkfTunable.value`), ``fields`` as given, the rest the defaults; InputError ``"{what}: <reason>"``."""
    cmkf = CmkfConfig(**{t.field: t.value(value(t)) for t in tunables}, **fields)
    try:
        cmkf.validate()
    except ValueError as exc:
        raise InputError(f"{what}: {exc}") from None
    return cmkf


def cmkf_config(config: OnlineConfig) -> CmkfConfig:
    """The CMKF's parameters from ``cmkf.*`` and ``nis.window`` (0 noise std: from the messages; ``cmkf.input_latency``:
    ``late_odom_tolerance``); InputError naming the parameter of an invalid combination."""
    return tuned_config((t for t in CMKF_TUNABLES if t.parameter is not None),
                        lambda t: getattr(config, t.spec().attr), "parameter cmkf.*")
