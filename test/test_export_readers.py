"""Each export loaded by its consumer's own reader, no mocks.

- OpenCV's ``cv::FileStorage`` (``cv2.FileStorage``), which OpenVINS (``ov_core/src/utils/opencv_yaml_parse.h``),
  VINS-Mono / VINS-Fusion (``parameters.cpp``) and ORB-SLAM3 (``Settings.cc``) read their settings with:
  ``kalibr_imu_chain.yaml``, ``vins_imu.yaml``, ``orbslam3_imu.yaml``.
- rclpy's parameter-file parser (``rclpy.parameter.parameter_dict_from_yaml_file``, as ``ros2 param load`` uses it):
  ``rep145_driver_params.yaml``.
- GTSAM itself (the ``gtsam`` Python package): its ``PreintegrationParams`` / ``PreintegrationCombinedParams`` built
  from ``gtsam_imu.yaml``, one measurement integrated, the preintegrated covariance compared with N²·dt and K²·dt.
- Kalibr's own checks on ``kalibr_imu.yaml`` (``ImuParameters``: PyYAML, every value > 0).

The files are the ones ``imu-noise-id export`` writes (with its run comment line), from the ``imu.yaml`` of
``test_exports.DOC``.
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml
from test_exports import DOC

from imu_noise_id.cli import main
from imu_noise_id.report.exports import write_exports
from imu_noise_id.report.imu_yaml import parse_imu_yaml

G = 9.80665  # [m/s²]


def _pyyaml(path: Path) -> dict:
    """The file as written, parsed by PyYAML (OpenCV's ``%YAML:1.0`` directive removed)."""
    return yaml.safe_load(path.read_text().removeprefix("%YAML:1.0\n"))


def _header(path: Path) -> str:
    return "".join(ln for ln in path.read_text().splitlines(keepends=True) if ln.startswith("#"))


@pytest.fixture(scope="module")
def exports(tmp_path_factory) -> Path:
    """The exports folder ``imu-noise-id export`` writes from an ``imu.yaml`` holding :data:`DOC`."""
    out = tmp_path_factory.mktemp("export_readers")
    (out / "imu.yaml").write_text(yaml.safe_dump(DOC))
    assert main(["export", str(out)]) == 0
    return out / "exports"


def _opencv(path: Path) -> cv2.FileStorage:
    """``cv::FileStorage(path, READ)`` as the consumers open their settings (it raises on a file it cannot parse)."""
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    assert fs.isOpened(), path
    return fs


def test_openvins_imu_chain_reads_in_opencv_as_openvins_reads_it(exports):
    path = exports / "kalibr_imu_chain.yaml"
    written = _pyyaml(path)["imu0"]
    fs = _opencv(path)
    imu0 = fs.getNode("imu0")
    assert imu0.isMap() and list(imu0.keys()) == list(written)
    # OpenVINS' parse(): the doubles by `file_node[name] >> value`, model and rostopic as strings
    for key in ("accelerometer_noise_density", "accelerometer_random_walk", "gyroscope_noise_density",
                "gyroscope_random_walk", "time_offset", "update_rate"):
        assert imu0.getNode(key).isReal(), key
        assert imu0.getNode(key).real() == written[key], key
    assert imu0.getNode("gyroscope_noise_density").real() == DOC["gyroscope_noise_density"]
    assert imu0.getNode("model").string() == "kalibr" and imu0.getNode("rostopic").string() == "/imu0"
    # OpenVINS' parse() of an Eigen::Matrix4d: node[r][c] for r < size(), c < node[r].size()
    t = imu0.getNode("T_i_b")
    assert t.isSeq() and t.size() == 4 and all(t.at(r).isSeq() and t.at(r).size() == 4 for r in range(4))
    matrix = np.array([[t.at(r).at(c).real() for c in range(4)] for r in range(4)])
    np.testing.assert_array_equal(matrix, np.eye(4))
    np.testing.assert_array_equal(matrix, np.array(written["T_i_b"]))
    fs.release()


def test_vins_fragment_reads_in_opencv_with_g_norm(exports):
    path = exports / "vins_imu.yaml"
    written = _pyyaml(path)
    fs = _opencv(path)
    root = fs.root()
    # VINS' readParameters: ACC_N = fsSettings["acc_n"], ..., G.z() = fsSettings["g_norm"] (0 when absent)
    assert list(root.keys()) == list(written) == ["acc_n", "gyr_n", "acc_w", "gyr_w", "g_norm"]
    for key in written:
        assert fs.getNode(key).isReal() and fs.getNode(key).real() == written[key], key
    assert fs.getNode("g_norm").real() == G
    assert fs.getNode("acc_n").real() == pytest.approx(DOC["accelerometer_noise_density"] * math.sqrt(2 * 200.0))
    fs.release()
    assert "Fragment" in _header(path)  # the rest of the VINS config comes from the user's file


def test_orbslam3_fragment_reads_in_opencv_as_real_numbers(exports):
    path = exports / "orbslam3_imu.yaml"
    written = _pyyaml(path)
    fs = _opencv(path)
    assert list(fs.root().keys()) == list(written)
    # ORB-SLAM3's Settings::readParameter<float> aborts unless the node isReal()
    for key in ("IMU.NoiseGyro", "IMU.NoiseAcc", "IMU.GyroWalk", "IMU.AccWalk", "IMU.Frequency"):
        node = fs.getNode(key)
        assert node.isReal() and node.real() == written[key], key
    assert fs.getNode("IMU.NoiseGyro").real() == DOC["gyroscope_noise_density"]
    fs.release()
    header = _header(path)
    assert "Fragment" in header and "IMU.T_b_c1" in header  # the extrinsics come from the user's calibration


def test_rep145_file_loads_in_rclpy_parameter_parser(exports):
    from rcl_interfaces.msg import ParameterType
    from rclpy.parameter import parameter_dict_from_yaml_file

    path = exports / "rep145_driver_params.yaml"
    expected = {"angular_velocity_stddev": 2.4e-3, "linear_acceleration_stddev": 0.022}
    # the /** entry (every node's parameters) is what use_wildcard selects; without it rclpy reads only the entries
    # of named nodes, and a file without the <node>: ros__parameters: level is rejected either way
    params = parameter_dict_from_yaml_file(str(path), use_wildcard=True)
    assert set(params) == set(expected)
    for name, value in expected.items():
        assert params[name].value.type == ParameterType.PARAMETER_DOUBLE
        assert params[name].value.double_value == value
    assert yaml.safe_load(path.read_text()) == {"/**": {"ros__parameters": expected}}
    assert "Convention: per-sample standard deviation" in _header(path)  # the header comment is kept


def _gtsam_params(doc: dict):
    """GTSAM's combined parameters from a gtsam_imu.yaml as its header says to set them (null: zero)."""
    import gtsam

    p = gtsam.PreintegrationCombinedParams.MakeSharedU(G)
    p.setAccelerometerCovariance(np.array(doc["accelerometerCovariance"]))
    p.setGyroscopeCovariance(np.array(doc["gyroscopeCovariance"]))
    p.setIntegrationCovariance(np.zeros((3, 3)) if doc["integrationCovariance"] is None
                               else np.array(doc["integrationCovariance"]))
    p.setBiasAccCovariance(np.array(doc["biasAccCovariance"]))
    p.setBiasOmegaCovariance(np.array(doc["biasOmegaCovariance"]))
    return p


def test_gtsam_preintegration_of_one_step_gives_the_densities_times_dt(exports):
    import gtsam

    doc = _pyyaml(exports / "gtsam_imu.yaml")
    dt = 1.0 / DOC["update_rate"]
    n_acc, n_gyr = DOC["accelerometer_noise_density"], DOC["gyroscope_noise_density"]
    k_acc, k_gyr = DOC["accelerometer_random_walk"], DOC["gyroscope_random_walk"]
    p = _gtsam_params(doc)
    # one value per sensor on the diagonal: the max over its axes (the Kalibr keys), as the header says; the
    # comparisons hold to the file's 6 significant digits
    np.testing.assert_allclose(p.getAccelerometerCovariance(), np.eye(3) * n_acc**2, rtol=1e-6, atol=0)
    np.testing.assert_allclose(p.getBiasOmegaCovariance(), np.eye(3) * k_gyr**2, rtol=1e-6, atol=0)
    # PreintegratedImuMeasurements: states (rotation, position, velocity); GTSAM adds B (aCov/dt) Bᵀ with
    # B_velocity = R·dt, so after one step of dt at rest the velocity variance is (N²/dt)·dt² = N²·dt.
    bias = gtsam.imuBias.ConstantBias()
    pim = gtsam.PreintegratedImuMeasurements(p, bias)
    pim.integrateMeasurement(np.array([0.0, 0.0, G]), np.zeros(3), dt)
    cov = pim.preintMeasCov()
    np.testing.assert_allclose(cov[6:9, 6:9], np.eye(3) * n_acc**2 * dt, rtol=1e-6, atol=0)
    np.testing.assert_allclose(cov[0:3, 0:3], np.eye(3) * n_gyr**2 * dt, rtol=1e-6, atol=0)
    # PreintegratedCombinedMeasurements adds the bias random walks: dt·biasAccCovariance, dt·biasOmegaCovariance
    combined = gtsam.PreintegratedCombinedMeasurements(p, bias)
    combined.integrateMeasurement(np.array([0.0, 0.0, G]), np.zeros(3), dt)
    cov = combined.preintMeasCov()
    np.testing.assert_allclose(cov[6:9, 6:9], np.eye(3) * n_acc**2 * dt, rtol=1e-6, atol=0)
    np.testing.assert_allclose(cov[9:12, 9:12], np.eye(3) * k_acc**2 * dt, rtol=1e-6, atol=0)
    np.testing.assert_allclose(cov[12:15, 12:15], np.eye(3) * k_gyr**2 * dt, rtol=1e-6, atol=0)


def test_gtsam_bias_covariance_never_pins_an_unidentified_bias(tmp_path):
    # the accelerometer's y random walk not identified, its Allan reading ~0: GTSAM would hold that bias constant
    doc = {**DOC, "accelerometer_random_walk_xyz": [3.0e-4, 1.0e-10, 2.5e-4],
           "accelerometer_random_walk_method_xyz": ["model", "allan_slope", "model"]}
    path = write_exports(parse_imu_yaml(doc), tmp_path, ("gtsam",))[0]
    gt = _pyyaml(path)
    for key, sensor in (("biasAccCovariance", "accelerometer"), ("biasOmegaCovariance", "gyroscope")):
        np.testing.assert_allclose(np.array(gt[key]), np.eye(3) * doc[f"{sensor}_random_walk"] ** 2, rtol=1e-6, atol=0)
    assert "the sensor's value is used on every axis" in _header(path)


def test_kalibr_checks_hold(exports):
    doc = yaml.safe_load((exports / "kalibr_imu.yaml").read_text())  # Kalibr's ParametersBase reads with PyYAML
    numbers = {k: v for k, v in doc.items() if k != "rostopic"}
    assert set(numbers) == {"accelerometer_noise_density", "accelerometer_random_walk", "gyroscope_noise_density",
                            "gyroscope_random_walk", "update_rate"}
    assert all(isinstance(v, float) and math.isfinite(v) and v > 0 for v in numbers.values()), numbers
    assert isinstance(doc["rostopic"], str) and doc["rostopic"].startswith("/")
