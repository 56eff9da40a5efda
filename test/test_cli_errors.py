"""Bad input that used to end in a traceback (issue 12): one line naming what to fix, exit 2, before any work."""

from __future__ import annotations

import subprocess
import sys

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
