"""``imu-noise-id simulate``: the written bag holds the simulated model; bad input exits 2."""

from __future__ import annotations

import numpy as np
import pytest

from imu_noise_id.bag.reader import read_imu
from imu_noise_id.bag.topics import list_topics
from imu_noise_id.cli import main
from imu_noise_id.core.noise.modelspec import parse_imu_model
from imu_noise_id.core.simulation.static import simulate_static_imu

SPEC = "gyro: WN(1e-3)+RW(1e-5); accel: WN(2e-3)+RW(4e-4)"


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_simulate_writes_the_same_samples_as_the_core_simulation(tmp_path, capsys, storage):
    out = tmp_path / "sim"
    code = main(["simulate", "--model", SPEC, "--rate", "100", "--duration", "30", "--out", str(out),
                 "--seed", "7", "--storage", storage, "--topic", "/sensors/imu"])  # fmt: skip
    printed = capsys.readouterr().out
    assert code == 0
    assert f"wrote {out} ({storage}): 3000 sensor_msgs/Imu samples on /sensors/imu" in printed
    assert "gyro_x   [rad/s]  WN+RW: WN(noise_density=0.001) + RW(random_walk=1e-05)" in printed
    assert list_topics(out) == {"/sensors/imu": ("sensor_msgs/msg/Imu", 3000)}
    expected = simulate_static_imu(parse_imu_model(SPEC), 100.0, 30.0, seed=7)
    got = read_imu(out)
    np.testing.assert_array_equal(got.gyro, expected.gyro)
    np.testing.assert_array_equal(got.accel, expected.accel)
    np.testing.assert_allclose(got.t, expected.t, rtol=0, atol=1e-9)
    assert got.notes == []


def test_simulate_from_yaml_files(tmp_path, capsys):
    spec_file = tmp_path / "model.yaml"
    spec_file.write_text("gyro: WN(1e-3)\naccel: WN(2e-3)+GM(tau=100, sigma=1e-3)\n")
    assert main(["simulate", "--model", str(spec_file), "--rate", "50", "--duration", "4",
                 "--out", str(tmp_path / "a"), "--seed", "1"]) == 0  # fmt: skip
    assert "accel_z  [m/s^2]  WN+GM: WN(noise_density=0.002) + GM(tau=100, sigma=0.001)" in capsys.readouterr().out
    # A model.yaml as written by the analysis (axes → components with continuous-time parameters).
    result_file = tmp_path / "result.yaml"
    axes = "\n".join(
        f"  {a}:\n    model: WN+RW\n    components:\n      - {{type: WN, noise_density: 0.003, se: 1e-5}}\n"
        f"      - {{type: RW, random_walk: 2.0e-5}}"
        for a in ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
    )
    result_file.write_text(f"axes:\n{axes}\n")
    assert main(["simulate", "--model", str(result_file), "--rate", "50", "--duration", "4",
                 "--out", str(tmp_path / "b")]) == 0  # fmt: skip
    assert "accel_y  [m/s^2]  WN+RW: WN(noise_density=0.003) + RW(random_walk=2e-05)" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--model", "gyro: XX(1)"], "unknown component 'XX'"),
        (["--model", "gyro: WN(1e-3)"], "IMU model gives no spec for accel_x"),
        (["--model", "missing.yaml"], "model file 'missing.yaml' does not exist"),
        (["--model", "WN(1e-3)", "--rate", "-5"], "--rate must be in (0, 100000] Hz"),
        (["--model", "WN(1e-3)", "--duration", "0"], "--duration must be > 0 s"),
        (["--model", "WN(1e-3)", "--start-time", "-1"], "--start-time must be >= 0 s"),
    ],
)
def test_simulate_bad_input_exits_2(tmp_path, capsys, args, message):
    base = {"--rate": "100", "--duration": "1", "--out": str(tmp_path / "x")}
    for key, value in zip(args[::2], args[1::2], strict=True):
        base[key] = value
    argv = ["simulate"] + [item for pair in base.items() for item in pair]
    if "--model" not in base:
        argv += ["--model", "WN(1e-3)"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("imu-noise-id simulate: error: ") and message in err
    assert not (tmp_path / "x").exists()


def test_simulate_refuses_to_overwrite(tmp_path, capsys):
    (tmp_path / "x").mkdir()
    argv = ["simulate", "--model", "WN(1e-3)", "--rate", "10", "--duration", "1", "--out", str(tmp_path / "x")]
    assert main(argv) == 2
    assert "exists already" in capsys.readouterr().err


def test_simulate_help_exits_0(capsys):
    with pytest.raises(SystemExit) as info:
        main(["simulate", "--help"])
    assert info.value.code == 0
    assert "--model MODEL" in capsys.readouterr().out
