"""One renderer per consumer: the analysis's numbers in (:class:`~..pipelines.analyze.numbers.PastedNumbers`: N
[u/√Hz], K [u/s/√Hz], f the update rate [Hz]), the consumer's file text out under a header stating source, convention
and formula: Kalibr, OpenVINS, ORB-SLAM3 continuous-time N, K; VINS acc_n = N·√(2f), acc_w = K·√f; GTSAM I·N², I·K²;
PX4 EKF2 N/√P, K/√P (P the EKF step [s]); REP-145 the per-sample standard deviation. Sources of each convention:
docs/analysis.md, "Exports".
"""

from __future__ import annotations

import math

import yaml

from ..core.constants import STANDARD_GRAVITY
from ..core.noise.units import step_noise_std
from ..pipelines.analyze.numbers import UPPER_BOUND_METHODS, PastedNumbers
from .numbers import num

_SENSORS = (("gyroscope", "gyro"), ("accelerometer", "acc"))
#: PX4's EKF prediction period (EKF2_PREDICT_US default, module.yaml) [s].
PX4_PREDICT_PERIOD_S = 0.01
#: PX4's documented (min, max) of each parameter (module.yaml, params_gyro_bias.yaml, params_accel_bias.yaml).
PX4_LIMITS = {"EKF2_GYR_NOISE": (1e-4, 0.1), "EKF2_ACC_NOISE": (0.01, 1.0), "EKF2_GYR_B_NOISE": (0.0, 0.01),
              "EKF2_ACC_B_NOISE": (0.0, 0.01)}
#: VINS' per-step weights of the measurement noise (mid-point rule) and of the bias noise.
VINS_NOISE_WEIGHT, VINS_WALK_WEIGHT = 0.5, 1.0
#: The node name of the REP-145 parameter file: ``/**`` matches every node (ROS 2 parameter files' wildcard).
ROS_PARAMETER_NODE = "/**"


class _IndentedSequences(yaml.SafeDumper):
    """PyYAML's safe dumper with block sequences indented under their key (as OpenCV's FileStorage reads them)."""

    def increase_indent(self, flow: bool = False, indentless: bool = False) -> None:
        return super().increase_indent(flow, False)


def _origin(numbers: PastedNumbers) -> list[str]:
    lines = [f"Written by imu-noise-id from {numbers.topic or '?'} at {numbers.rate_hz:g} Hz."]
    ob = numbers.values_of
    if ob:
        lines.append(f"OVERBOUND values (imu.yaml 'overbound:'): {ob}")
    else:
        lines.append("Values: imu.yaml's Kalibr keys (each sensor's max over x, y, z of the final models' values).")
    if not ob:
        lines += _walk_notes(numbers)
    return lines


def _walk_notes(numbers: PastedNumbers) -> list[str]:
    """Per sensor whose Kalibr K (the maximum over its axes) is not a final model's value: which axis it is and what
    it is (an upper bound, or the Allan-slope reading standing in for a model without a walk)."""
    notes = []
    for s in numbers.sensors.values():
        readings = [a for a in s.axes if a.random_walk.value is not None and math.isfinite(a.random_walk.value)]
        if not readings:
            continue
        top = max(readings, key=lambda a: a.random_walk.value)
        method, key = top.random_walk.method, f"{s.prefix}_random_walk"
        if method in UPPER_BOUND_METHODS:
            notes.append(f"Note: {key} is {top.axis}'s upper bound ({method}): the record does not resolve that walk "
                         "(it may be far smaller); a longer record gives a value.")
        elif method.startswith("allan"):
            notes.append(f"Note: {key} is {top.axis}'s Allan-slope reading ({method}): its final model has no random "
                         "walk.")
    return notes


def header(numbers: PastedNumbers, *convention: str, prefix: str = "# ") -> str:
    """The comment lines of a file: origin, convention, formula."""
    return "".join(f"{prefix}{line}\n" for line in [*_origin(numbers), *convention])


def _yaml_number(value: float) -> str:
    """A float with 6 significant digits as YAML writes it (``2.0e-05``: readable as a number by every parser)."""
    return yaml.safe_dump(float(f"{value:.6g}")).splitlines()[0]


_SENSOR_OF = {"gyroscope": "gyro", "accelerometer": "accel"}


def _n(numbers: PastedNumbers, sensor: str) -> float:
    """Kalibr's N of ``sensor`` (``gyroscope`` or ``accelerometer``)."""
    return numbers.sensor(_SENSOR_OF[sensor]).noise_density


def _k(numbers: PastedNumbers, sensor: str) -> float:
    """Kalibr's K of ``sensor``."""
    return numbers.sensor(_SENSOR_OF[sensor]).random_walk


def kalibr(numbers: PastedNumbers) -> str:
    """Kalibr's own ``imu.yaml`` (the six keys its ``ImuParameters`` reads)."""
    body = ""
    for sensor, unit, walk_unit in (("accelerometer", "m/s^2", "m/s^3"), ("gyroscope", "rad/s", "rad/s^2")):
        body += (f"{sensor}_noise_density: {_yaml_number(_n(numbers, sensor))}  # [{unit}/sqrt(Hz)] noise density "
                 "(continuous-time)\n"
                 f"{sensor}_random_walk: {_yaml_number(_k(numbers, sensor))}  # [{walk_unit}/sqrt(Hz)] bias random "
                 "walk\n")
    body += (f"rostopic: {numbers.topic or '/imu0'}\n"
             f"update_rate: {_yaml_number(numbers.rate_hz)}  # [Hz] Kalibr discretises "
             "sigma_d = N*sqrt(update_rate)\n")
    return header(numbers, "Convention: Kalibr's, continuous-time N [u/sqrt(Hz)] and K [u/s/sqrt(Hz)]; Kalibr "
                           "refuses values <= 0.") + body


def openvins(numbers: PastedNumbers) -> str:
    """OpenVINS / Kalibr IMU chain (continuous-time densities) that OpenCV's ``cv::FileStorage`` reads key by key:
    ``T_i_b`` a sequence of four rows of four numbers, block-indented under its key."""
    imu0 = {"T_i_b": [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]],
            **{f"{s}_{p}": getattr(numbers.sensor(_SENSOR_OF[s]), p) for s in ("accelerometer", "gyroscope")
               for p in ("noise_density", "random_walk")},
            "model": "kalibr", "rostopic": numbers.topic or "/imu0", "time_offset": 0.0,
            "update_rate": numbers.rate_hz}
    body = yaml.dump({"imu0": imu0}, Dumper=_IndentedSequences, sort_keys=False, default_flow_style=None)
    return "%YAML:1.0\n" + header(numbers, "Convention: continuous-time noise densities N [u/sqrt(Hz)] and bias "
                                           "random walks K [u/s/sqrt(Hz)], as Kalibr; T_i_b identity (set your "
                                           "extrinsics)") + body


def orbslam3(numbers: PastedNumbers) -> str:
    """ORB-SLAM3 IMU settings (continuous-time; ORB-SLAM3 scales by sqrt(IMU.Frequency)), every value a real number;
    a fragment: the header names the keys (``IMU.T_b_c1``) that must come from the user's settings file."""
    body = {"IMU.NoiseGyro": _n(numbers, "gyroscope"), "IMU.NoiseAcc": _n(numbers, "accelerometer"),
            "IMU.GyroWalk": _k(numbers, "gyroscope"), "IMU.AccWalk": _k(numbers, "accelerometer"),
            "IMU.Frequency": numbers.rate_hz}
    return "%YAML:1.0\n" + header(
        numbers, "Convention: continuous-time: NoiseGyro/NoiseAcc in rad/s/sqrt(Hz), m/s^2/sqrt(Hz); GyroWalk/AccWalk "
                 "in rad/s^2/sqrt(Hz), m/s^3/sqrt(Hz)",
        "Fragment: merge these keys into your ORB-SLAM3 settings file; IMU.T_b_c1 (the 4x4 opencv-matrix from "
        "camera 1 to the IMU body, from your camera-IMU calibration) and the camera keys must come from it.") + \
        yaml.safe_dump(body, sort_keys=False)


def vins(numbers: PastedNumbers) -> str:
    """VINS-Mono / VINS-Fusion ``acc_n``, ``gyr_n``, ``acc_w``, ``gyr_w`` (per-IMU-step standard deviations) and
    ``g_norm`` (standard gravity); a fragment of the VINS config, as its header says."""
    f = numbers.rate_hz
    values = {}
    for sensor, short in (("accelerometer", "acc"), ("gyroscope", "gyr")):
        values[f"{short}_n"] = step_noise_std(_n(numbers, sensor), 1.0 / f, VINS_NOISE_WEIGHT)
    for sensor, short in (("accelerometer", "acc"), ("gyroscope", "gyr")):
        values[f"{short}_w"] = step_noise_std(_k(numbers, sensor), 1.0 / f, VINS_WALK_WEIGHT)
    body = "".join(f"{k}: {_yaml_number(v)}\n" for k, v in values.items())
    body += f"g_norm: {_yaml_number(STANDARD_GRAVITY)}  # [m/s^2] standard gravity: set your local value\n"
    return "%YAML:1.0\n" + header(
        numbers, "Convention: VINS propagates per IMU step dt = 1/update_rate (integration_base.h): the mid-point step "
             "adds (dt/2)^2*acc_n^2 for each of its two samples, the bias dt^2*acc_w^2.",
        f"Formula: acc_n = N*sqrt(2*f), acc_w = K*sqrt(f), f = {f:g} Hz (same for gyr_*), so that the propagated "
        "variances grow as N^2*t and K^2*t.",
        "acc_n [m/s^2], gyr_n [rad/s], acc_w [m/s^3], gyr_w [rad/s^2]. The often-quoted Kalibr discrete values "
        "N*sqrt(f) and K/sqrt(f) differ from these by sqrt(2) and by f.",
        "Fragment: merge these keys into your VINS config (VINS reads g_norm as 0 when it is absent); the topics, "
        "the camera calibration and the camera-IMU extrinsics must come from it.") + body


def _diag(value: float) -> list[list[float]]:
    """I·value² as rows (:func:`~.numbers.num` digits)."""
    return [[num(value**2) if i == j else 0.0 for j in range(3)] for i in range(3)]


def gtsam(numbers: PastedNumbers) -> str:
    """GTSAM ``PreintegrationCombinedParams`` members (continuous-time covariances, densities squared): I·N², I·K² with
    each sensor's Kalibr value (max over its axes) on every axis, never an axis's own (docs/analysis.md, "Exports")."""
    body = {"accelerometerCovariance": _diag(_n(numbers, "accelerometer")),
            "gyroscopeCovariance": _diag(_n(numbers, "gyroscope")),
            "biasAccCovariance": _diag(_k(numbers, "accelerometer")),
            "biasOmegaCovariance": _diag(_k(numbers, "gyroscope")),
            "integrationCovariance": None, "biasAccOmegaInt": None}
    return header(
        numbers, "Convention: GTSAM's continuous-time 'covariances' = densities squared, the sensor's value (max over "
                 "x, y, z) on each axis of the diagonal: accelerometerCovariance = I*N^2 [(m/s^2)^2/Hz], "
                 "gyroscopeCovariance [(rad/s)^2/Hz] (GTSAM divides by dt), biasAccCovariance = I*K^2 "
                 "[(m/s^3)^2/Hz], biasOmegaCovariance [(rad/s^2)^2/Hz] (GTSAM multiplies by dt).",
        "Not the per-axis values of imu.yaml's *_xyz: where an axis's random walk is not identifiable its value can "
        "be ~0, and that bias covariance would hold the bias constant; the sensor's value is used on every axis.",
        "integrationCovariance (integration error) and biasAccOmegaInt (uncertainty of the initial bias; GTSAM 4.3 "
        "has none: put a prior on the first bias) are choices of your estimator, not properties of the IMU: not "
        "identifiable from a static record, left null.",
        "Use: p = gtsam.PreintegrationCombinedParams.MakeSharedU(g); p.setAccelerometerCovariance(np.array(...)); "
        "... (PreintegrationParams takes the first two only).") + \
        yaml.safe_dump(body, sort_keys=False, default_flow_style=None)


def px4_period(rate_hz: float) -> float:
    """PX4's EKF prediction period [s]: EKF2_PREDICT_US's default as a whole number of IMU periods."""
    return max(1, round(PX4_PREDICT_PERIOD_S * rate_hz)) / rate_hz


def px4(numbers: PastedNumbers) -> str:
    """PX4 EKF2 noise parameters as a QGroundControl ``.params`` file (tab-separated, MAV_PARAM_TYPE 9 = float)."""
    period = px4_period(numbers.rate_hz)
    values = {"EKF2_ACC_B_NOISE": step_noise_std(_k(numbers, "accelerometer"), period),
              "EKF2_ACC_NOISE": step_noise_std(_n(numbers, "accelerometer"), period),
              "EKF2_GYR_B_NOISE": step_noise_std(_k(numbers, "gyroscope"), period),
              "EKF2_GYR_NOISE": step_noise_std(_n(numbers, "gyroscope"), period)}
    notes = [f"Note: {name} = {v:.3g} lies outside PX4's documented range [{lo:g}, {hi:g}]"
             for name, v in values.items() for lo, hi in [PX4_LIMITS[name]] if not lo <= v <= hi]
    head = header(
        numbers, f"Convention: PX4 EKF2 adds sq(P*EKF2_GYR_NOISE) per prediction step of P = {period * 1e3:g} ms "
             f"(EKF2_PREDICT_US default {PX4_PREDICT_PERIOD_S * 1e6:g} us as whole IMU periods) "
             "(EKF/covariance.cpp).",
        "Formula: EKF2_*_NOISE = N/sqrt(P) [rad/s, m/s^2], EKF2_*_B_NOISE = K/sqrt(P) [rad/s^2, m/s^3]; for another "
        "EKF2_PREDICT_US multiply by sqrt(P/P_new). Not Kalibr's discrete sigma_d = N*sqrt(IMU rate).", *notes)
    rows = "".join(f"1\t1\t{name}\t{v:.7g}\t9\n" for name, v in values.items())  # a float32's digits
    return "# Onboard parameters for Vehicle 1\n#\n" + head + "#\n# Vehicle-Id Component-Id Name Value Type\n" + rows


def rep145(numbers: PastedNumbers) -> str:
    """REP-145 driver parameters: per-sample standard deviations at the driver's rate, as a ROS 2 parameter file
    (``/**: ros__parameters:``, which every node reads)."""
    per_sample = {}
    for sensor, name in (("gyro", "angular_velocity_stddev"), ("accel", "linear_acceleration_stddev")):
        per_sample[name] = float(numbers.sensor(sensor).noise_stddev_per_sample(numbers.rate_hz))
    return header(numbers, "Convention: per-sample standard deviation at update_rate (rad/s, m/s^2): sqrt of the "
                           "sensor_msgs/Imu covariance diagonal; includes the sensor's own low-pass, not N*sqrt(rate) "
                           "(an overbound or an Allan-only analysis has no low-pass: N*sqrt(rate))",
                  f"ROS 2 parameter file: {ROS_PARAMETER_NODE} gives every node these parameters; put your driver's "
                  "node name there to give them to it alone.") + \
        yaml.safe_dump({ROS_PARAMETER_NODE: {"ros__parameters": per_sample}}, sort_keys=False)
