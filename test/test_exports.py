"""The filters' exports: each format's own keys (as in its documented example file) and units (issue 13)."""

from __future__ import annotations

import math

import pytest
import yaml

from imu_noise_id.cli import main
from imu_noise_id.report.exports import write_exports

#: An imu.yaml as analyze writes it (values of a 200 Hz MEMS IMU, the accelerometer's RW not identified).
DOC = {"gyroscope_noise_density": 1.7e-4, "gyroscope_random_walk": 2.0e-5, "accelerometer_noise_density": 2.0e-3,
       "accelerometer_random_walk": 3.0e-4, "update_rate": 200.0, "rostopic": "/imu0",
       "gyroscope_noise_stddev_per_sample_xyz": [2.4e-3, 2.3e-3, 2.4e-3],
       "accelerometer_noise_stddev_per_sample_xyz": [0.021, 0.022, 0.020],
       "gyroscope_random_walk_method_xyz": ["model", "model", "model"],
       "accelerometer_random_walk_method_xyz": ["model", "allan_upper_bound", "model"]}


def _load(path):
    text = path.read_text()
    return text, yaml.safe_load(text.removeprefix("%YAML:1.0\n"))


def test_openvins_is_kalibrs_imu_chain_with_continuous_densities(tmp_path):
    text, doc = _load(write_exports(DOC, tmp_path, ("openvins",))[0])
    # OpenVINS' kalibr_imu_chain.yaml example: %YAML:1.0, imu0 with T_i_b, the four densities, model, rostopic,
    # time_offset, update_rate
    assert text.startswith("%YAML:1.0\n")
    assert list(doc) == ["imu0"] and set(doc["imu0"]) == {
        "T_i_b", "accelerometer_noise_density", "accelerometer_random_walk", "gyroscope_noise_density",
        "gyroscope_random_walk", "model", "rostopic", "time_offset", "update_rate"}
    imu0 = doc["imu0"]
    assert imu0["model"] == "kalibr" and imu0["T_i_b"] == [[float(i == j) for j in range(4)] for i in range(4)]
    assert imu0["gyroscope_noise_density"] == DOC["gyroscope_noise_density"] and imu0["update_rate"] == 200.0
    assert "continuous-time" in text and "allan_upper_bound" in text  # the convention and the caveat are stated


def test_orbslam3_settings_are_continuous_time(tmp_path):
    text, doc = _load(write_exports(DOC, tmp_path, ("orbslam3",))[0])
    assert doc == {"IMU.NoiseGyro": 1.7e-4, "IMU.NoiseAcc": 2.0e-3, "IMU.GyroWalk": 2.0e-5, "IMU.AccWalk": 3.0e-4,
                   "IMU.Frequency": 200.0}
    assert text.startswith("%YAML:1.0\n")


def test_rep145_driver_parameters_are_per_sample_stddevs(tmp_path):
    _, doc = _load(write_exports(DOC, tmp_path, ("rep145",))[0])
    assert doc == {"angular_velocity_stddev": 2.4e-3, "linear_acceleration_stddev": 0.022}
    # An Allan-only imu.yaml has no per-sample values: white noise sampled at the rate, σ = N·√f.
    allan_only = {k: v for k, v in DOC.items() if "per_sample" not in k}
    _, doc = _load(write_exports(allan_only, tmp_path / "a", ("rep145",))[0])
    assert doc["angular_velocity_stddev"] == pytest.approx(1.7e-4 * math.sqrt(200.0))


def test_export_command(tmp_path, capsys):
    (tmp_path / "imu.yaml").write_text(yaml.safe_dump(DOC))
    assert main(["export", str(tmp_path), "--format", "orbslam3"]) == 0
    assert (tmp_path / "exports" / "orbslam3_imu.yaml").exists()
    assert main(["export", str(tmp_path / "nothing.yaml")]) == 2
    (tmp_path / "bad.yaml").write_text("gyroscope_noise_density: 1\n")
    assert main(["export", str(tmp_path / "bad.yaml")]) == 2
    assert "lacks" in capsys.readouterr().err
