"""A unit with one working sensor (a gyro-only unit whose driver fills linear_acceleration with zeros): analysed
through ``--axis``, the other sensor left out of every stage, the static check included.

Before, every command refused such a bag ("accel_x is constant … no noise can be identified") with nothing to do
about it, and ``fit``/``loop`` refused it as soon as they ran ``analyze``'s Allan stage."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from imu_noise_id.bag.writer import write_bag
from imu_noise_id.cli import main
from imu_noise_id.core.axes import AXES, ImuSeries
from imu_noise_id.core.noise.components import RW, WN
from imu_noise_id.core.simulation.static import simulate_static_imu


@pytest.fixture(scope="module")
def gyro_only_bag(tmp_path_factory):
    imu = simulate_static_imu({a: [WN(1e-3), RW(1e-5)] for a in AXES}, 100.0, 200.0, seed=13)
    imu = ImuSeries(imu.t, imu.gyro, np.zeros_like(imu.accel), imu.frame_id, imu.topic)
    return write_bag(tmp_path_factory.mktemp("fog") / "fog", imu)


def test_the_dead_sensor_is_named_with_what_to_do(gyro_only_bag, tmp_path, capsys):
    assert main(["analyze", str(gyro_only_bag), "--out", str(tmp_path / "a")]) == 2
    err = capsys.readouterr().err
    assert "accel_x is constant" in err and "--axis gyro" in err and "Traceback" not in err


def test_the_live_sensor_is_analysed_alone(gyro_only_bag, tmp_path, capsys):
    out = tmp_path / "a"
    assert main(["analyze", str(gyro_only_bag), "--axis", "gyro_z", "--model", "WN+RW", "--no-loop",
                 "--out", str(out)]) == 0
    doc = yaml.safe_load((out / "imu.yaml").read_text())
    assert doc["gyroscope_noise_density"] == pytest.approx(1e-3, rel=0.05)
    assert not any(key.startswith("accelerometer") for key in doc)
    assert not (out / "exports").exists()
    assert any("only the gyro analysed" in w for w in doc["warnings"])
    assert main(["export", str(out)]) == 2
    assert "gyroscope's numbers alone" in capsys.readouterr().err
    assert main(["fit", str(gyro_only_bag), "--axis", "gyro_x", "--model", "WN", "--out", str(tmp_path / "f")]) == 0
    fitted = yaml.safe_load((tmp_path / "f" / "model.yaml").read_text())["axes"]
    assert set(fitted) == {"gyro_x"}
