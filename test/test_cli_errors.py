"""Bad input that used to end in a traceback (issue 12): one line naming what to fix, exit 2, before any work."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from imu_noise_id.cli import main


@pytest.mark.parametrize("out_kind", ["file", "unreachable"])
def test_an_unusable_out_is_refused_before_any_work(tmp_path, capsys, out_kind):
    out = tmp_path / "a_file"
    out.write_text("x")
    target = out if out_kind == "file" else out / "sub"  # a directory under a file cannot be created
    # the bag does not exist either: the --out check comes first, so nothing is read
    assert main(["analyze", str(tmp_path / "no_bag"), "--out", str(target)]) == 2
    err = capsys.readouterr().err
    assert "--out" in err and "Traceback" not in err and "no_bag" not in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("argv, fragment", [
    (["criteria", "--case", "1", "--trials", "2", "--duration", "inf"], "--duration"),
    (["criteria", "--case", "1", "--trials", "1000000000"], "--trials"),
    (["simulate", "--model", "gyro: WN(1e308); accel: WN(1e-3)", "--rate", "100", "--duration", "1"],
     "noise_density"),
])
def test_absurd_numbers_are_refused(tmp_path, capsys, argv, fragment):
    assert main([*argv, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert fragment in err and "Traceback" not in err


def test_a_closed_pipe_is_not_a_traceback(tmp_path):
    cmd = [sys.executable, "-m", "imu_noise_id", "simulate", "--model", "gyro: WN(1e-3); accel: WN(1e-3)", "--rate",
           "100", "--duration", "2", "--out", str(tmp_path / "bag")]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader leaves at once, like `| head -0`
    assert proc.wait(timeout=60) == 0
    assert b"Traceback" not in proc.stderr.read()
    assert (tmp_path / "bag").exists()


def test_missing_topic_messages_name_the_right_option_and_example(tmp_path, capsys):
    """cmkf said "Pass --topic" while its option was --imu-topic, and "Record the Odometry topic (e.g. /imu/data)"."""
    assert main(["simulate", "--model", "gyro: WN(1e-3); accel: WN(1e-3)", "--rate", "100", "--duration", "2",
                 "--out", str(tmp_path / "bag")]) == 0
    capsys.readouterr()
    assert main(["cmkf", str(tmp_path / "bag"), "--topic", "/nope", "--out", str(tmp_path / "o")]) == 2
    assert "Pass --topic" in capsys.readouterr().err  # and --topic is an option of cmkf
    assert main(["cmkf", str(tmp_path / "bag"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "Odometry" in err and "/odom" in err and "/imu/data)" not in err


def test_a_model_spec_longer_than_a_file_name_is_a_spec(tmp_path, capsys):
    """simulate asked whether a 300-character spec was a file (OSError: File name too long)."""
    spec = "gyro: WN(1e-3)" + "+WN(1e-4)" * 40 + "; accel: WN(1e-3)"
    assert len(spec) > 255
    assert main(["simulate", "--model", spec, "--rate", "50", "--duration", "1", "--out", str(tmp_path / "b")]) == 0
    assert main(["simulate", "--model", "x" * 300 + ".yaml", "--rate", "50", "--duration", "1",
                 "--out", str(tmp_path / "c")]) == 2
    assert main(["inspect", str(tmp_path / ("y" * 300 + ".mcap"))]) == 2
    err = capsys.readouterr().err
    assert "does not exist" in err and "File name too long" in err and "Traceback" not in err


def _npz(path, **arrays):
    np.savez(path, **arrays)
    return path


@pytest.mark.parametrize("content, fragment", [
    (b"PK\x03\x04" + b"garbage" * 20, "is not a readable .npz"),
    ({"t": np.arange(10.0), "gyro": np.zeros((5, 3)), "accel": np.zeros((10, 3))}, "one row per sample"),
    ({"fs_hz": np.array([1.0, 2.0]), "gyro": np.zeros((500, 3)), "accel": np.zeros((500, 3))}, "fs_hz must be"),
    ({"fs_hz": 0.0, "gyro": np.zeros((500, 3)), "accel": np.zeros((500, 3))}, "fs_hz must be"),
    ({"t": np.arange(500.0), "gyro": np.zeros((500, 4)), "accel": np.zeros((500, 3))}, "must be (N, 3)"),
    ({"t": np.arange(500.0), "gyro": np.array(["a"] * 1500).reshape(500, 3), "accel": np.zeros((500, 3))},
     "is not numeric"),
    ({"t": np.full(500, np.nan), "gyro": np.zeros((500, 3)), "accel": np.zeros((500, 3))}, "NaN/inf"),
])
def test_malformed_npz_is_one_message(tmp_path, capsys, content, fragment):
    path = tmp_path / "x.npz"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        _npz(path, **content)
    assert main(["analyze", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert fragment in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("content", [bytes(range(256)) * 4, b"\x00\x01\x02abc", b"- [unclosed\n  : x"])
def test_a_binary_or_broken_hypotheses_file_is_one_message(tmp_path, capsys, content):
    bag = tmp_path / "bag"
    assert main(["simulate", "--model", "gyro: WN(1e-3); accel: WN(1e-3)", "--rate", "50", "--duration", "5",
                 "--out", str(bag)]) == 0
    (tmp_path / "h.yaml").write_bytes(content)
    capsys.readouterr()
    assert main(["identify", str(bag), "--hypotheses", str(tmp_path / "h.yaml"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "hypotheses file" in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_inspect_reads_an_imu_bag_whose_optional_odometry_is_all_nan(tmp_path, capsys):
    from test_bag_reader import simulated_imu, simulated_odometry

    from imu_noise_id.bag.writer import write_bag

    odom = simulated_odometry(50)
    for name in ("position", "orientation_xyzw", "linear_velocity", "angular_velocity"):
        getattr(odom, name)[:] = np.nan
    write_bag(tmp_path / "bag", simulated_imu(duration=10.0), odom)
    assert main(["inspect", str(tmp_path / "bag")]) == 0
    out = capsys.readouterr().out
    assert "looks static" in out and "note: /odom: not used" in out and "all 50 samples have NaN/inf" in out
