"""Bad input to the bag reader: each case gives a clear BagError (exit code 2 in the CLI) or a noted repair."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_bag_reader import simulated_imu, simulated_odometry

from imu_noise_id.bag.errors import BagError
from imu_noise_id.bag.reader import IMU_TYPE, TEMPERATURE_TYPE, read_bag, read_imu, read_odometry
from imu_noise_id.bag.writer import encode_cdr, write_bag
from imu_noise_id.cli import main
from imu_noise_id.core.axes import ImuSeries, ScalarSeries
from imu_noise_id.core.errors import InputError


def cli(*args: str, capsys) -> tuple[int, str, str]:
    code = main(["inspect", *args])
    out, err = capsys.readouterr()
    return code, out, err


def write_raw_topics(path: Path, topics: dict[str, str], n: int = 50) -> Path:
    """A rosbag2 mcap bag with ``n`` zero-valued messages on each topic (topic → msgtype)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    ns = 1_700_000_000_000_000_000 + 10_000_000 * np.arange(n)
    stamps = {"header.stamp.sec": ns // 10**9, "header.stamp.nanosec": ns % 10**9}
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        for topic, msgtype in topics.items():
            conn = writer.add_connection(topic, msgtype, typestore=store)
            buf, _ = encode_cdr(store.fielddefs, msgtype, stamps, {})
            for i in range(n):
                writer.write(conn, int(ns[i]), buf[i].tobytes())
    return path


@pytest.fixture(scope="module")
def good_bag(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("good") / "bag"
    write_bag(path, simulated_imu(duration=10.0), simulated_odometry(50), storage="mcap")
    return path


def _copy_storage_file(bag: Path, dst: Path) -> Path:
    shutil.copytree(bag, dst)
    return next(p for p in dst.iterdir() if p.suffix in (".mcap", ".db3"))


# --- files ------------------------------------------------------------------------------------------------------


def test_missing_path(tmp_path, capsys):
    with pytest.raises(BagError, match=r"does not exist: give a ROS 1 .bag file, a rosbag2 directory"):
        read_imu(tmp_path / "nope.mcap")
    code, _, err = cli(str(tmp_path / "nope"), capsys=capsys)
    assert code == 2 and "imu-noise-id inspect: error: bag" in err and "does not exist" in err


def test_not_a_bag_and_empty_files(tmp_path):
    (tmp_path / "notes.txt").write_text("hello")
    with pytest.raises(BagError, match=r"is not a bag"):
        read_imu(tmp_path / "notes.txt")
    (tmp_path / "empty.mcap").write_bytes(b"")
    with pytest.raises(BagError, match=r"rosbag2 mcap file .*empty.mcap' is empty \(0 bytes\): re-record it"):
        read_imu(tmp_path / "empty.mcap")
    (tmp_path / "garbage.db3").write_bytes(b"not a database" * 100)
    with pytest.raises(BagError, match=r"cannot open rosbag2 sqlite3 file .* file is not a database"):
        read_imu(tmp_path / "garbage.db3")
    (tmp_path / "dir").mkdir()
    with pytest.raises(BagError, match=r"cannot open rosbag2 directory .*metadata"):
        read_imu(tmp_path / "dir")


def test_bag_without_messages(tmp_path, capsys):
    empty = ImuSeries(t=np.empty(0), gyro=np.empty((0, 3)), accel=np.empty((0, 3)))
    write_bag(tmp_path / "bag", empty)
    with pytest.raises(BagError, match=r"contains no messages \(topics: /imu/data \(sensor_msgs/msg/Imu, 0 msgs\)\)"):
        read_imu(tmp_path / "bag")
    assert cli(str(tmp_path / "bag"), capsys=capsys)[0] == 2


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_truncated_rosbag2(tmp_path, storage, capsys):
    """Cut in half: the complete messages are read with a note of the loss (test_truncated_bags.py has more)."""
    path = tmp_path / "bag"
    write_bag(path, simulated_imu(duration=10.0), storage=storage)
    data = _copy_storage_file(path, tmp_path / "cut")
    os.truncate(data, data.stat().st_size // 2)
    got = read_imu(tmp_path / "cut")
    assert 300 < len(got) < 700 and "is damaged (cut short)" in got.notes[0]
    code, out, _ = cli(str(tmp_path / "cut"), capsys=capsys)
    assert code == 0 and "lost (metadata.yaml counts): /imu/data" in out


def test_truncated_and_garbled_ros1_bag(shared_data, tmp_path):
    raw = (shared_data / "husky_robot_localization" / "test1.bag").read_bytes()
    (tmp_path / "cut.bag").write_bytes(raw[: len(raw) // 2])
    got = read_bag(tmp_path / "cut.bag")
    assert 4000 < len(got.imu) < 6000 and "cut.bag is damaged (cut short)" in got.imu.notes[0]
    garbled = bytearray(raw)
    garbled[len(raw) // 2 : len(raw) // 2 + 64] = bytes(range(64))
    (tmp_path / "garbled.bag").write_bytes(bytes(garbled))
    with pytest.raises(
        BagError, match=r"garbled.bag' is truncated or corrupt: reading failed with \d+ of 15817 messages decoded"
    ):
        read_bag(tmp_path / "garbled.bag")


def test_corrupt_message_in_mcap(good_bag, tmp_path):
    """A string length field overwritten: the message no longer deserialises → error, not wrong numbers."""
    data = _copy_storage_file(good_bag, tmp_path / "bad")
    content = bytearray(data.read_bytes())
    at = content.index(b"imu_link\x00", len(content) // 2)
    content[at - 4 : at] = b"\xff\xff\xff\x7f"
    data.write_bytes(bytes(content))
    with pytest.raises(BagError, match=r"is truncated or corrupt: reading failed with \d+ of \d+ messages decoded"):
        read_imu(tmp_path / "bad")


# --- topics -----------------------------------------------------------------------------------------------------


def test_no_imu_topic(tmp_path, capsys):
    path = write_raw_topics(tmp_path / "bag", {"/temperature": TEMPERATURE_TYPE})
    with pytest.raises(BagError, match=r"no sensor_msgs/msg/Imu topic in .*its topics are: /temperature"):
        read_imu(path)
    code, out, err = cli(str(path), capsys=capsys)
    assert code == 2 and "/temperature" in out and "Record the Imu topic" in err


def test_several_imu_topics_need_topic(tmp_path, capsys):
    path = write_raw_topics(tmp_path / "bag", {"/imu/a": IMU_TYPE, "/imu/b": IMU_TYPE})
    with pytest.raises(BagError, match=r"has 2 Imu topics: /imu/a \(.*50 msgs\), /imu/b .*Pass --topic"):
        read_imu(path)
    assert cli(str(path), capsys=capsys)[0] == 2
    assert len(read_imu(path, "/imu/b")) == 50
    assert cli(str(path), "--topic", "/imu/b", capsys=capsys)[0] == 0


def test_wrong_type_and_unknown_topic(good_bag, capsys):
    with pytest.raises(BagError) as info:
        read_imu(good_bag, "/odom")
    assert str(info.value).startswith("topic '/odom' in rosbag2 directory")
    assert "has type nav_msgs/msg/Odometry, not sensor_msgs/msg/Imu" in str(info.value)
    assert "Imu topics there: /imu/data (sensor_msgs/msg/Imu, 1000 msgs)" in str(info.value)
    with pytest.raises(BagError, match=r"topic '/imu' is not in .*Imu topics there: /imu/data"):
        read_imu(good_bag, "/imu")
    code, _, err = cli(str(good_bag), "--topic", "/odom", capsys=capsys)
    assert code == 2 and "not sensor_msgs/msg/Imu" in err


def test_missing_odometry_when_required(tmp_path):
    path = tmp_path / "bag"
    write_bag(path, simulated_imu(duration=2.0))
    with pytest.raises(BagError, match=r"no nav_msgs/msg/Odometry topic"):
        read_odometry(path)
    with pytest.raises(BagError, match=r"no nav_msgs/msg/Odometry topic"):
        read_bag(path, require_odometry=True)
    assert read_bag(path).odom is None


# --- samples and stamps (repairs) ------------------------------------------------------------------------------


def _imu_with(t: np.ndarray, imu: ImuSeries) -> ImuSeries:
    return ImuSeries(t=t, gyro=imu.gyro, accel=imu.accel)


def test_nan_samples_dropped_with_note_or_error_when_all_bad(tmp_path, capsys):
    imu = simulated_imu(duration=10.0)
    imu.gyro[[3, 30], 1] = np.nan
    imu.accel[300, 2] = np.inf
    write_bag(tmp_path / "some", imu)
    got = read_imu(tmp_path / "some")
    assert len(got) == len(imu) - 3 and np.all(np.isfinite(got.gyro))
    assert got.topic == "/imu/data" and "dropped 3 of 1000 messages with NaN/inf time or values" in got.notes[0]
    code, out, _ = cli(str(tmp_path / "some"), capsys=capsys)
    assert code == 0 and "note: dropped 3 of 1000 messages with NaN/inf" in out
    imu.accel[:, 0] = np.nan
    write_bag(tmp_path / "all", imu)
    with pytest.raises(BagError, match=r"topic '/imu/data' in .*: all 1000 samples have NaN/inf time or values"):
        read_imu(tmp_path / "all")
    assert cli(str(tmp_path / "all"), capsys=capsys)[0] == 2


def test_out_of_order_and_duplicated_stamps(tmp_path):
    imu = simulated_imu(duration=10.0)
    order = np.arange(len(imu))
    order[[10, 11]] = order[[11, 10]]
    shuffled = ImuSeries(t=imu.t[order], gyro=imu.gyro[order], accel=imu.accel[order])
    write_bag(tmp_path / "order", shuffled)
    got = read_imu(tmp_path / "order")
    assert got.notes == ["stamps went backwards 1 time(s): messages sorted by stamp"]
    np.testing.assert_array_equal(got.gyro, imu.gyro)
    dup = np.r_[0:500, 499 : len(imu)]
    write_bag(tmp_path / "dup", ImuSeries(t=imu.t[dup], gyro=imu.gyro[dup], accel=imu.accel[dup]))
    got = read_imu(tmp_path / "dup")
    assert got.notes == ["dropped 1 messages with a duplicated stamp (kept the first)"]
    np.testing.assert_array_equal(got.accel, imu.accel)


def test_gaps_are_noted_with_time_and_length(tmp_path):
    imu = simulated_imu(duration=10.0, t0=1.7e9)
    keep = np.ones(len(imu), dtype=bool)
    keep[200:450] = False  # 2.5 s missing after t = 1.99 s
    write_bag(tmp_path / "gap", ImuSeries(t=imu.t[keep], gyro=imu.gyro[keep], accel=imu.accel[keep]))
    got = read_imu(tmp_path / "gap")
    assert len(got.notes) == 1
    assert "1 gap(s) longer than 1.5× the period 0.01 s (≈250 missing messages" in got.notes[0]
    assert "at t=1.990 s for 2.510 s" in got.notes[0]


def test_zero_stamps(tmp_path):
    imu = simulated_imu(duration=5.0, t0=1.7e9)
    # All header stamps unset: the bag's receive times are used instead, with a note.
    write_bag(tmp_path / "zeros", _imu_with(np.zeros(len(imu)), imu), receive_t=imu.t)
    got = read_imu(tmp_path / "zeros")
    assert "every header stamp is zero" in got.notes[0] and "receive times" in got.notes[0]
    np.testing.assert_allclose(got.t, imu.t, rtol=0, atol=3e-7)
    # A few unset stamps among clock stamps: those messages are dropped.
    t = imu.t.copy()
    t[[100, 200]] = 0.0
    write_bag(tmp_path / "some", _imu_with(t, imu), receive_t=imu.t)
    got = read_imu(tmp_path / "some")
    assert got.notes[0] == "dropped 2 messages with a zero header stamp (stamp not set)"
    assert got.notes[1].startswith("2 gap(s)")  # the dropped messages leave holes, reported as gaps
    assert len(got) == len(imu) - 2


def test_impossible_values_dropped(tmp_path):
    imu = simulated_imu(duration=10.0)
    imu.gyro[7, 0] = 1e300  # what a corrupt payload looks like
    write_bag(tmp_path / "bag", imu)
    got = read_imu(tmp_path / "bag")
    assert got.notes[0] == "dropped 1 messages with physically impossible values (corrupt data or wrong units)"
    assert np.abs(got.gyro).max() < 1.0


def test_non_static_data_flagged_by_inspect(shared_data, capsys):
    code, out, _ = cli(str(shared_data / "husky_robot_localization" / "test1.bag"), capsys=capsys)
    assert code == 0 and "not static (a static noise analysis of these data would be wrong)" in out
    assert "gyro_y: the 1 s means vary" in out
    assert "declared angular_velocity_covariance diag (0.0004, 0.0004, 0.0004) (rad/s)²" in out
    assert "odometry /husky_velocity_controller/odom: 3952 messages" in out


def test_errors_are_input_errors_and_no_traceback_in_a_subprocess(tmp_path, ros_env):
    assert issubclass(BagError, InputError)
    proc = subprocess.run(
        [sys.executable, "-m", "imu_noise_id", "inspect", str(tmp_path / "missing.bag")],
        capture_output=True,
        text=True,
        env=ros_env,
        check=False,
        timeout=60,
    )
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and "does not exist" in proc.stderr


def test_temperature_optional(tmp_path):
    imu = simulated_imu(duration=2.0)
    write_bag(tmp_path / "t", imu, temperature=ScalarSeries(t=imu.t[::10], value=np.full(20, 30.5)))
    bag = read_bag(tmp_path / "t")
    assert bag.temperature is not None and np.all(bag.temperature.value == 30.5)
