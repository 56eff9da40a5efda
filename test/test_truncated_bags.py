"""Bags cut short (a recorder killed, a copy interrupted): the complete messages are read and the loss is said.

Before the fix a ``.mcap``, ``.db3`` or ROS 1 ``.bag`` cut anywhere after its header gave nothing but an error whose
hint (``ros2 bag reindex``) cannot repair data cut short (issue 12).
"""

from __future__ import annotations

import re
import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pytest
from crafted import cut_file, static_imu, write_ros1_bag

from imu_noise_id.bag.errors import BagError
from imu_noise_id.bag.reader import read_bag, read_imu
from imu_noise_id.bag.writer import write_bag
from imu_noise_id.cli import main

N = 3000  # 30 s at 100 Hz


@pytest.fixture(scope="module")
def imu():
    return static_imu(rate=100.0, duration=30.0)


@pytest.fixture(scope="module")
def bags(tmp_path_factory, imu) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("whole")
    return {"mcap": write_bag(root / "mcap", imu, storage="mcap"),
            "sqlite3": write_bag(root / "sqlite3", imu, storage="sqlite3"),
            "ros1": write_ros1_bag(root / "whole.bag", imu),
            "ros1_bz2": write_ros1_bag(root / "whole_bz2.bag", imu, compression="bz2")}


def _cut(bags: dict[str, Path], kind: str, fraction: float, dst: Path) -> Path:
    src = bags[kind]
    if src.is_file():
        return cut_file(src, dst / src.name, fraction)
    shutil.copytree(src, dst / kind)
    data = next(p for p in (dst / kind).iterdir() if p.suffix in (".mcap", ".db3"))
    cut_file(src / data.name, data, fraction)
    return dst / kind


@pytest.mark.parametrize("kind", ["mcap", "sqlite3", "ros1", "ros1_bz2"])
@pytest.mark.parametrize("fraction", [0.99, 0.7, 0.3])
def test_a_cut_bag_yields_its_complete_messages_and_says_what_was_lost(bags, imu, kind, fraction, tmp_path):
    bag = read_bag(_cut(bags, kind, fraction, tmp_path))
    n = len(bag.imu)
    assert 0.1 * N < n <= N and n > (fraction - 0.25) * N
    np.testing.assert_array_equal(bag.imu.gyro, imu.gyro[:n])  # exactly the first messages, nothing invented
    np.testing.assert_allclose(bag.imu.t, imu.t[:n], rtol=0, atol=1e-6)
    note = next(x for x in bag.notes if "is damaged" in x)
    assert f"read {n} complete messages" in note
    if n == N:  # the cut fell after the data (a compressed bag's index is a larger share of it)
        assert "nothing lost" in note
    elif kind in ("mcap", "sqlite3"):  # metadata.yaml survived: the loss is exact
        assert f"lost (metadata.yaml counts): /imu/data {N - n} of {N}" in note
    else:  # ROS 1: estimated from the bytes the bag header announces
        lost = int(re.search(r"about (\d+) messages", note).group(1))
        assert abs(lost - (N - n)) < 0.3 * (N - n) + 50


@pytest.mark.parametrize("kind", ["mcap", "ros1"])
def test_a_cut_in_the_index_loses_nothing(bags, kind, tmp_path):
    src = bags[kind]
    data = src if src.is_file() else next(src.glob("*.mcap"))
    size = data.stat().st_size
    keep = size - 200  # inside the summary (mcap) / the index records (ROS 1), after every chunk
    bag = read_bag(_cut(bags, kind, keep / size, tmp_path))
    assert len(bag.imu) == N and any("nothing lost" in x for x in bag.notes)


def test_a_killed_recorder_without_metadata_is_read_with_an_estimate(bags, tmp_path):
    bag = _cut(bags, "mcap", 0.6, tmp_path)
    (bag / "metadata.yaml").unlink()  # ros2 bag record writes it when it closes
    got = read_bag(bag)
    note = next(x for x in got.notes if "is damaged" in x)
    assert 0.4 * N < len(got.imu) < 0.7 * N and "it ends inside a record: about" in note


def test_a_file_cut_inside_its_first_record_is_one_clear_error(bags, tmp_path, capsys):
    for kind, keep in (("mcap", 30), ("sqlite3", 50), ("ros1", 100)):  # inside the file's header record
        (tmp_path / kind).mkdir()
        src = bags[kind] if bags[kind].is_file() else next(p for p in bags[kind].iterdir() if p.name != "metadata.yaml")
        bag = _cut(bags, kind, keep / src.stat().st_size, tmp_path / kind)
        with pytest.raises(BagError, match=r"damaged|cannot open") as info:
            read_imu(bag)
        assert "reindex` rebuild a missing index, not data cut short" in str(info.value) or \
            "holds no complete message" in str(info.value)
        assert main(["inspect", str(bag)]) == 2
    assert "Traceback" not in capsys.readouterr().err


def test_an_uncheckpointed_write_ahead_log_is_read_and_a_cut_one_in_part(tmp_path, imu):
    """rosbags opens sqlite3 bags as immutable and would ignore the WAL: the later half of the messages."""
    from imu_noise_id.core.axes import ImuSeries

    whole = write_bag(tmp_path / "whole", imu, storage="sqlite3")
    rows = sqlite3.connect(whole / "whole.db3").execute(
        "SELECT topic_id, timestamp, data FROM messages ORDER BY id").fetchall()
    half = N // 2
    first = ImuSeries(t=imu.t[:half], gyro=imu.gyro[:half], accel=imu.accel[:half])
    live = write_bag(tmp_path / "live", first, storage="sqlite3")
    con = sqlite3.connect(live / "live.db3")
    con.execute("PRAGMA journal_mode=WAL")
    con.execute("PRAGMA wal_autocheckpoint=0")
    con.executemany("INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)", rows[half:])
    con.commit()
    crashed = tmp_path / "crashed"
    shutil.copytree(live, crashed)  # what a power cut leaves: the db and its uncheckpointed log
    con.close()
    got = read_bag(crashed)
    assert len(got.imu) == N and any("write-ahead log" in x for x in got.notes)
    np.testing.assert_array_equal(got.imu.gyro, imu.gyro)
    wal = crashed / "live.db3-wal"
    cut_file(wal, wal, 0.5)
    got = read_bag(crashed)
    assert half < len(got.imu) < N
    np.testing.assert_array_equal(got.imu.gyro, imu.gyro[: len(got.imu)])


def test_analyze_on_a_cut_bag_goes_on_and_says_so(bags, tmp_path, capsys):
    bag = _cut(bags, "mcap", 0.9, tmp_path)
    assert main(["analyze", str(bag), "--model", "none", "--out", str(tmp_path / "out")]) == 0
    err = capsys.readouterr().err
    assert "is damaged (cut short)" in err and "lost (metadata.yaml counts)" in err
