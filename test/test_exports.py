"""The filters' exports: each format's own keys (as in its documented example file) and units (issue 13).

Where a consumer discretises, the numbers are checked by running that consumer's documented propagation (as its
code does it, written here in numpy) on the exported values: the variances it accumulates over a time t must be
the continuous-time truth N²·t and K²·t.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from imu_noise_id.cli import main
from imu_noise_id.report.export_formats import px4_period
from imu_noise_id.report.exports import FORMATS, write_exports
from imu_noise_id.report.imu_yaml import parse_imu_yaml

#: An imu.yaml as analyze writes it (values of a 200 Hz MEMS IMU, the accelerometer's RW not identified).
DOC = {"gyroscope_noise_density": 1.7e-4, "gyroscope_random_walk": 2.0e-5, "accelerometer_noise_density": 2.0e-3,
       "accelerometer_random_walk": 3.0e-4, "update_rate": 200.0, "rostopic": "/imu0",
       "gyroscope_noise_stddev_per_sample_xyz": [2.4e-3, 2.3e-3, 2.4e-3],
       "accelerometer_noise_stddev_per_sample_xyz": [0.021, 0.022, 0.020],
       "gyroscope_random_walk_method_xyz": ["model", "model", "model"],
       "accelerometer_random_walk_method_xyz": ["model", "allan_upper_bound", "model"],
       "gyroscope_noise_density_xyz": [1.6e-4, 1.7e-4, 1.5e-4], "gyroscope_random_walk_xyz": [2.0e-5, 1.8e-5, 1.9e-5],
       "accelerometer_noise_density_xyz": [2.0e-3, 1.9e-3, 1.8e-3],
       "accelerometer_random_walk_xyz": [3.0e-4, 2.0e-4, 2.5e-4]}
T = 10.0  # [s] the time over which the propagated variances are compared with N²·t, K²·t


def _load(path):
    text = path.read_text()
    return text, yaml.safe_load(text.removeprefix("%YAML:1.0\n"))


def test_openvins_is_kalibrs_imu_chain_with_continuous_densities(tmp_path):
    text, doc = _load(write_exports(parse_imu_yaml(DOC), tmp_path, ("openvins",))[0])
    # OpenVINS' kalibr_imu_chain.yaml example: %YAML:1.0, imu0 with T_i_b, the four densities, model, rostopic,
    # time_offset, update_rate
    assert text.startswith("%YAML:1.0\n")
    assert list(doc) == ["imu0"] and set(doc["imu0"]) == {
        "T_i_b", "accelerometer_noise_density", "accelerometer_random_walk", "gyroscope_noise_density",
        "gyroscope_random_walk", "model", "rostopic", "time_offset", "update_rate"}
    imu0 = doc["imu0"]
    assert imu0["model"] == "kalibr" and imu0["T_i_b"] == [[float(i == j) for j in range(4)] for i in range(4)]
    assert imu0["gyroscope_noise_density"] == DOC["gyroscope_noise_density"] and imu0["update_rate"] == 200.0
    assert "continuous-time" in text  # the convention is stated
    # accel_y's walk is a bound, but the pasted maximum is accel_x's model value: no caveat on it
    assert "Note: accelerometer_random_walk" not in text


def test_orbslam3_settings_are_continuous_time(tmp_path):
    text, doc = _load(write_exports(parse_imu_yaml(DOC), tmp_path, ("orbslam3",))[0])
    assert doc == {"IMU.NoiseGyro": 1.7e-4, "IMU.NoiseAcc": 2.0e-3, "IMU.GyroWalk": 2.0e-5, "IMU.AccWalk": 3.0e-4,
                   "IMU.Frequency": 200.0}
    assert text.startswith("%YAML:1.0\n") and "Fragment:" in text and "IMU.T_b_c1" in text


def test_rep145_driver_parameters_are_per_sample_stddevs(tmp_path):
    _, doc = _load(write_exports(parse_imu_yaml(DOC), tmp_path, ("rep145",))[0])
    # a ROS 2 parameter file: the /** node (every node), its ros__parameters
    assert doc == {"/**": {"ros__parameters": {"angular_velocity_stddev": 2.4e-3, "linear_acceleration_stddev": 0.022}}}
    # An Allan-only imu.yaml has no per-sample values: white noise sampled at the rate, σ = N·√f.
    allan_only = {k: v for k, v in DOC.items() if "per_sample" not in k}
    _, doc = _load(write_exports(parse_imu_yaml(allan_only), tmp_path / "a", ("rep145",))[0])
    assert doc["/**"]["ros__parameters"]["angular_velocity_stddev"] == pytest.approx(1.7e-4 * math.sqrt(200.0))


def test_export_command(tmp_path, capsys):
    (tmp_path / "imu.yaml").write_text(yaml.safe_dump(DOC))
    assert main(["export", str(tmp_path), "--format", "orbslam3"]) == 0
    assert (tmp_path / "exports" / "orbslam3_imu.yaml").exists()
    assert main(["export", str(tmp_path / "nothing.yaml")]) == 2
    (tmp_path / "bad.yaml").write_text("gyroscope_noise_density: 1\n")
    assert main(["export", str(tmp_path / "bad.yaml")]) == 2
    assert "lacks" in capsys.readouterr().err


def test_kalibr_is_kalibrs_own_imu_yaml(tmp_path):
    text, doc = _load(write_exports(parse_imu_yaml(DOC), tmp_path, ("kalibr",))[0])
    # Kalibr's ImuParameters (kalibr_common/ConfigReader.py) reads exactly these six keys and refuses <= 0
    assert set(doc) == {"accelerometer_noise_density", "accelerometer_random_walk", "gyroscope_noise_density",
                        "gyroscope_random_walk", "rostopic", "update_rate"}
    assert isinstance(doc["rostopic"], str) and doc["update_rate"] == 200.0
    assert all(doc[k] > 0 for k in doc if k.endswith(("_density", "_walk")))
    assert doc["gyroscope_noise_density"] == DOC["gyroscope_noise_density"]
    # Kalibr's discretisation, as ConfigReader does it: N / sqrt(1 / update_rate)
    sigma_d = doc["gyroscope_noise_density"] / math.sqrt(1.0 / doc["update_rate"])
    assert sigma_d == pytest.approx(1.7e-4 * math.sqrt(200))
    assert "continuous-time" in text


def test_a_pasted_walk_that_is_a_bound_is_said_to_be_one_with_its_axis(tmp_path):
    """Where the maximum over a sensor's axes is a bound, every export says which key, whose and what it is."""
    bound_on_top = {**DOC, "accelerometer_random_walk": 4.0e-4,
                    "accelerometer_random_walk_xyz": [3.0e-4, 4.0e-4, 2.5e-4]}
    for path in write_exports(parse_imu_yaml(bound_on_top), tmp_path):
        text = path.read_text()
        assert "Note: accelerometer_random_walk is accel_y's upper bound (allan_upper_bound)" in text, path.name
        assert "Note: gyroscope_random_walk" not in text, path.name


def test_vins_values_give_the_true_variances_through_vins_propagation(tmp_path):
    text, doc = _load(write_exports(parse_imu_yaml(DOC), tmp_path, ("vins",))[0])
    assert text.startswith("%YAML:1.0\n")
    assert list(doc) == ["acc_n", "gyr_n", "acc_w", "gyr_w", "g_norm"]  # VINS' euroc_config.yaml keys
    assert doc["g_norm"] == 9.80665 and "Fragment:" in text
    dt = 1.0 / DOC["update_rate"]
    # integration_base.h: noise = diag(acc_n², gyr_n², acc_n², gyr_n², acc_w², gyr_w²); per step P += V noise Vᵀ
    # with V = ½dt on the measurement noises of both ends of the mid-point step (angle θ, velocity v) and V = dt
    # on the bias noises (b_a, b_g); at rest F = I on these states.
    noise = np.diag([doc["acc_n"] ** 2, doc["gyr_n"] ** 2, doc["acc_n"] ** 2, doc["gyr_n"] ** 2, doc["acc_w"] ** 2,
                     doc["gyr_w"] ** 2])
    V = np.zeros((4, 6))  # states θ, v, b_a, b_g
    V[0, 1] = V[0, 3] = 0.5 * dt
    V[1, 0] = V[1, 2] = 0.5 * dt
    V[2, 4] = V[3, 5] = dt
    P = np.zeros((4, 4))
    for _ in range(round(T / dt)):
        P = P + V @ noise @ V.T
    assert P[0, 0] == pytest.approx(DOC["gyroscope_noise_density"] ** 2 * T, rel=1e-5)
    assert P[1, 1] == pytest.approx(DOC["accelerometer_noise_density"] ** 2 * T, rel=1e-5)
    assert P[2, 2] == pytest.approx(DOC["accelerometer_random_walk"] ** 2 * T, rel=1e-5)
    assert P[3, 3] == pytest.approx(DOC["gyroscope_random_walk"] ** 2 * T, rel=1e-5)
    assert "acc_n = N*sqrt(2*f)" in text and "acc_w = K*sqrt(f)" in text


def test_gtsam_covariances_are_continuous_densities_squared_per_sensor(tmp_path):
    text, doc = _load(write_exports(parse_imu_yaml(DOC), tmp_path, ("gtsam",))[0])
    # the members of PreintegrationCombinedParams (CombinedImuFactorsExample: p->accelerometerCovariance = I·σ², …)
    assert set(doc) == {"accelerometerCovariance", "gyroscopeCovariance", "biasAccCovariance", "biasOmegaCovariance",
                        "integrationCovariance", "biasAccOmegaInt"}
    assert doc["integrationCovariance"] is None and doc["biasAccOmegaInt"] is None  # not IMU properties
    acc = np.array(doc["accelerometerCovariance"])
    assert acc.shape == (3, 3) and np.count_nonzero(acc - np.diag(np.diag(acc))) == 0
    # one value per sensor, the max over its axes (the Kalibr key), as the header says: not the *_xyz values
    np.testing.assert_allclose(np.sqrt(np.diag(acc)), [DOC["accelerometer_noise_density"]] * 3, rtol=1e-6)
    # GTSAM's propagation (ImuFactor.cpp / CombinedImuFactor.cpp): per step the velocity gets
    # vel_H_acc (aCov/dt) vel_H_accᵀ with vel_H_acc = R·dt, the bias dt·biasAccCovariance.
    dt = 1.0 / DOC["update_rate"]
    steps = round(T / dt)
    vel = steps * dt * (acc / dt) * dt
    bias = steps * dt * np.array(doc["biasOmegaCovariance"])
    np.testing.assert_allclose(np.diag(vel), [DOC["accelerometer_noise_density"] ** 2 * T] * 3, rtol=1e-6)
    np.testing.assert_allclose(np.diag(bias), [DOC["gyroscope_random_walk"] ** 2 * T] * 3, rtol=1e-6)
    assert "integrationCovariance" in text and "not identifiable" in text


def _qgc_params(text):
    """A QGroundControl .params file: '#' comments, rows 'vehicle component name value type' (tab-separated)."""
    rows = [ln.split("\t") for ln in text.splitlines() if ln and not ln.startswith("#")]
    assert all(len(r) == 5 and r[:2] == ["1", "1"] for r in rows)
    return {r[2]: (float(r[3]), int(r[4])) for r in rows}


def test_px4_parameters_give_the_true_variances_through_ekf2_prediction(tmp_path):
    text = write_exports(parse_imu_yaml(DOC), tmp_path, ("px4",))[0].read_text()
    assert "# Vehicle-Id Component-Id Name Value Type" in text
    params = _qgc_params(text)
    assert set(params) == {"EKF2_GYR_NOISE", "EKF2_ACC_NOISE", "EKF2_GYR_B_NOISE", "EKF2_ACC_B_NOISE"}
    assert all(kind == 9 for _, kind in params.values())  # MAV_PARAM_TYPE_REAL32
    period = px4_period(DOC["update_rate"])
    assert period == pytest.approx(0.01)  # EKF2_PREDICT_US default at 200 Hz: 2 IMU samples per step
    # EKF/covariance.cpp: per prediction step d_ang_var = sq(dt * gyro_noise), bias += sq(dt * gyro_bias_p_noise)
    steps = round(T / period)
    for name, key in (("EKF2_GYR_NOISE", "gyroscope_noise_density"), ("EKF2_ACC_NOISE", "accelerometer_noise_density"),
                      ("EKF2_GYR_B_NOISE", "gyroscope_random_walk"), ("EKF2_ACC_B_NOISE", "accelerometer_random_walk")):
        # to the file's 7 significant digits (a float32 holds no more)
        assert steps * (period * params[name][0]) ** 2 == pytest.approx(DOC[key] ** 2 * T, rel=1e-6), name
    # in PX4's units (rad/s, m/s^2, rad/s^2, m/s^3): N/sqrt(P), not Kalibr's N*sqrt(IMU rate)
    assert params["EKF2_GYR_NOISE"][0] == pytest.approx(1.7e-4 / math.sqrt(0.01))
    assert "outside PX4's documented range" not in text
    # an accelerometer quieter than PX4's documented minimum of EKF2_ACC_NOISE (0.01 m/s^2) is flagged
    quiet_doc = parse_imu_yaml({**DOC, "accelerometer_noise_density": 5e-5})
    quiet = write_exports(quiet_doc, tmp_path / "q", ("px4",))[0].read_text()
    assert "EKF2_ACC_NOISE = 0.0005 lies outside PX4's documented range [0.01, 1]" in quiet


def test_every_format_states_its_convention_and_origin(tmp_path):
    for path in write_exports(parse_imu_yaml(DOC), tmp_path):
        text = path.read_text()
        assert "Convention:" in text and "/imu0 at 200 Hz" in text, path.name
    assert {p.name for p in tmp_path.iterdir()} == {name for name, _ in FORMATS.values()}


def test_overbound_exports_use_the_overbound_section(tmp_path):
    ob = {"gyroscope_noise_density": 3.4e-4, "gyroscope_random_walk": 8.0e-5, "accelerometer_noise_density": 4.0e-3,
          "accelerometer_random_walk": 9.0e-4, "gyroscope_noise_density_xyz": [3.4e-4, 3.0e-4, 3.1e-4],
          "tau_range_s": [0.005, 100.0], "inflation_summary": "N x1.8-2.0, K x4.0-4.4"}
    paths = write_exports(parse_imu_yaml({**DOC, "overbound": ob}), tmp_path, ("kalibr", "gtsam", "rep145"),
                          overbound=True)
    assert all(p.parent == tmp_path / "overbound" for p in paths)
    text, doc = _load(paths[0])
    assert doc["gyroscope_noise_density"] == 3.4e-4 and doc["accelerometer_random_walk"] == 9.0e-4
    assert "OVERBOUND" in text and "[0.005, 100] s" in text and "N x1.8-2.0" in text
    _, gt = _load(paths[1])
    assert np.sqrt(np.diag(gt["gyroscopeCovariance"])).tolist() == pytest.approx([3.4e-4] * 3)  # the sensor's max
    _, rep = _load(paths[2])  # no low-pass in a WN+RW: N*sqrt(f)
    assert rep["/**"]["ros__parameters"]["angular_velocity_stddev"] == pytest.approx(3.4e-4 * math.sqrt(200.0))
    with pytest.raises(Exception, match="no 'overbound:' section"):
        write_exports(parse_imu_yaml(DOC), tmp_path, ("kalibr",), overbound=True)


def test_export_command_formats_and_overbound(tmp_path, capsys):
    ob = {"gyroscope_noise_density": 3.4e-4, "gyroscope_random_walk": 8.0e-5, "accelerometer_noise_density": 4.0e-3,
          "accelerometer_random_walk": 9.0e-4, "tau_range_s": [0.005, 100.0]}
    (tmp_path / "imu.yaml").write_text(yaml.safe_dump({**DOC, "overbound": ob}))
    assert main(["export", str(tmp_path), "--format", "vins", "px4", "--overbound"]) == 0
    assert sorted(p.name for p in (tmp_path / "exports" / "overbound").iterdir()) == ["px4_ekf2.params",
                                                                                       "vins_imu.yaml"]
    assert main(["export", str(tmp_path)]) == 0
    assert {p.name for p in (tmp_path / "exports").iterdir() if p.is_file()} == {n for n, _ in FORMATS.values()}
    (tmp_path / "imu.yaml").write_text(yaml.safe_dump(DOC))
    assert main(["export", str(tmp_path), "--overbound"]) == 2
    assert "no 'overbound:' section" in capsys.readouterr().err
