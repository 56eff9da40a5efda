"""Exports of the noise figures for the filters people run, each in its own units and conventions.

Every export is written from the numbers of ``imu.yaml`` (the final models' values, max over each sensor's axes;
see :mod:`.imu_yaml`) and states its convention in a comment header:

- ``openvins`` → ``kalibr_imu_chain.yaml``: OpenVINS reads Kalibr's IMU chain file (``%YAML:1.0``, ``imu0:`` with
  ``model: "kalibr"``): continuous-time densities N [u/√Hz] and K [u/s/√Hz], as in ``imu.yaml``.
- ``orbslam3`` → ``orbslam3_imu.yaml``: ORB-SLAM3 settings ``IMU.NoiseGyro``, ``IMU.NoiseAcc`` (N, continuous-time
  [rad/s/√Hz], [m/s²/√Hz]), ``IMU.GyroWalk``, ``IMU.AccWalk`` (K [rad/s²/√Hz], [m/s³/√Hz]) and ``IMU.Frequency``
  [Hz]; ORB-SLAM3 itself multiplies by √frequency to get per-sample values.
- ``rep145`` → ``rep145_driver_params.yaml``: the REP-145 IMU driver parameters ``angular_velocity_stddev`` and
  ``linear_acceleration_stddev``: the *per-sample* standard deviation at the driver's rate that the driver puts
  (squared) into ``sensor_msgs/Imu`` covariances — ``*_noise_stddev_per_sample_xyz`` of ``imu.yaml`` (max over
  axes; it accounts for the sensor's own low-pass), not N·√rate.

Random walks that the final model could not identify carry the Allan-slope reading or bound of ``imu.yaml``
(``*_random_walk_method_xyz`` says which); the header repeats it.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import yaml

from ..core.errors import InputError

REQUIRED = ("gyroscope_noise_density", "gyroscope_random_walk", "accelerometer_noise_density",
            "accelerometer_random_walk", "update_rate")


def _header(doc: dict, convention: str) -> str:
    methods = [m for key in ("gyroscope_random_walk_method_xyz", "accelerometer_random_walk_method_xyz")
               for m in doc.get(key, []) if m != "model"]
    lines = [f"# Written by imu-noise-id from {doc.get('rostopic', '?')} at {doc['update_rate']:g} Hz (imu.yaml: "
             "the final models' values, max over each sensor's x, y, z).", f"# Convention: {convention}"]
    if methods:
        lines.append("# Note: some random walks are not identifiable from the record: Allan-slope reading or bound "
                     f"used ({', '.join(sorted(set(methods)))}).")
    return "\n".join(lines) + "\n"


def openvins(doc: dict) -> str:
    """OpenVINS / Kalibr IMU chain (continuous-time densities)."""
    imu0 = {"T_i_b": [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]],
            **{k: float(doc[k]) for k in REQUIRED[:4]}, "model": "kalibr",
            "rostopic": str(doc.get("rostopic", "/imu0")), "time_offset": 0.0, "update_rate": float(doc["update_rate"])}
    body = yaml.safe_dump({"imu0": imu0}, sort_keys=False, default_flow_style=None)
    return "%YAML:1.0\n" + _header(doc, "continuous-time noise densities N [u/sqrt(Hz)] and bias random walks K "
                                        "[u/s/sqrt(Hz)], as Kalibr; T_i_b identity (set your extrinsics)") + body


def orbslam3(doc: dict) -> str:
    """ORB-SLAM3 IMU settings (continuous-time; ORB-SLAM3 scales by sqrt(IMU.Frequency))."""
    body = {"IMU.NoiseGyro": float(doc["gyroscope_noise_density"]),
            "IMU.NoiseAcc": float(doc["accelerometer_noise_density"]),
            "IMU.GyroWalk": float(doc["gyroscope_random_walk"]), "IMU.AccWalk": float(doc["accelerometer_random_walk"]),
            "IMU.Frequency": float(doc["update_rate"])}
    return "%YAML:1.0\n" + _header(doc, "continuous-time: NoiseGyro/NoiseAcc in rad/s/sqrt(Hz), m/s^2/sqrt(Hz); "
                                        "GyroWalk/AccWalk in rad/s^2/sqrt(Hz), m/s^3/sqrt(Hz)") + \
        yaml.safe_dump(body, sort_keys=False)


def rep145(doc: dict) -> str:
    """REP-145 driver parameters: per-sample standard deviations at the driver's rate."""
    per_sample = {}
    for sensor, name in (("gyroscope", "angular_velocity_stddev"), ("accelerometer", "linear_acceleration_stddev")):
        values = doc.get(f"{sensor}_noise_stddev_per_sample_xyz")
        if values is None:  # Allan-only analysis: white noise sampled at the rate
            values = [float(doc[f"{sensor}_noise_density"]) * math.sqrt(float(doc["update_rate"]))]
        per_sample[name] = float(max(values))
    return _header(doc, "per-sample standard deviation at update_rate (rad/s, m/s^2): sqrt of the sensor_msgs/Imu "
                        "covariance diagonal; includes the sensor's own low-pass, not N*sqrt(rate)") + \
        yaml.safe_dump(per_sample, sort_keys=False)


FORMATS = {"openvins": ("kalibr_imu_chain.yaml", openvins), "orbslam3": ("orbslam3_imu.yaml", orbslam3),
           "rep145": ("rep145_driver_params.yaml", rep145)}


def write_exports(doc: dict, out_dir: Path, formats: tuple[str, ...] = tuple(FORMATS)) -> list[Path]:
    """Write the ``formats`` from the ``imu.yaml`` content ``doc`` into ``out_dir`` (temporary name, then rename).

    Raises
    ------
    InputError
        ``doc`` lacks a number an export needs, or a format is unknown.
    """
    missing = [k for k in REQUIRED if not isinstance(doc.get(k), int | float)]
    if missing:
        raise InputError(f"imu.yaml lacks {', '.join(missing)}: rerun imu-noise-id analyze")
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in formats:
        if name not in FORMATS:
            raise InputError(f"--format {name!r}: choose from {', '.join(FORMATS)} or all")
        filename, render = FORMATS[name]
        path = out_dir / filename
        tmp = path.with_name(f".{filename}.tmp")
        tmp.write_text(render(doc))
        os.replace(tmp, path)
        paths.append(path)
    return paths
