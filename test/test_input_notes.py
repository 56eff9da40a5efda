"""fit, identify and loop keep the reader's repair notes (issue 12): on stderr and in their YAML, as analyze does.

Before the fix ``fit`` and ``identify`` dropped every note (drops, sorting, duplicates, gaps, the receive-time
fallback): nothing on stderr, nothing in ``model.yaml`` / ``hypotheses.yaml``.
"""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from crafted import static_imu, with_stamps

from imu_noise_id.bag.writer import write_bag
from imu_noise_id.cli import main


@pytest.fixture(scope="module")
def repaired_bag(tmp_path_factory):
    """30 s at 100 Hz with 3 NaN messages, a swapped pair and a duplicated stamp."""
    imu = static_imu(rate=100.0, duration=30.0)
    imu.gyro[[5, 50, 500], 0] = np.nan
    t = imu.t.copy()
    t[[100, 101]] = t[[101, 100]]
    t[200] = t[199]
    path = tmp_path_factory.mktemp("notes") / "bag"
    write_bag(path, with_stamps(imu, t))
    return path


EXPECTED = ("dropped 3 of 3000 messages with NaN/inf", "stamps went backwards 1 time(s)",
            "dropped 1 messages with a duplicated stamp")


def _check(notes: list[str], err: str) -> None:
    for fragment in EXPECTED:
        assert any(fragment in n for n in notes), (fragment, notes)
        assert f"note: /imu/data: {fragment}" in err


def test_fit_keeps_the_notes(repaired_bag, tmp_path, capsys):
    assert main(["fit", str(repaired_bag), "--model", "WN+RW", "--axis", "gyro_z", "--starts", "1",
                 "--out", str(tmp_path)]) == 0
    doc = yaml.safe_load((tmp_path / "model.yaml").read_text())
    _check(doc["meta"]["notes"], capsys.readouterr().err)


def test_identify_keeps_the_notes(repaired_bag, tmp_path, capsys):
    assert main(["identify", str(repaired_bag), "--axis", "gyro_z", "--refine", "0", "--no-plot",
                 "--out", str(tmp_path)]) == 0
    doc = yaml.safe_load((tmp_path / "hypotheses.yaml").read_text())
    _check(doc["notes"], capsys.readouterr().err)


def test_receive_time_fallback_is_noted_by_fit(tmp_path, capsys):
    imu = static_imu(rate=100.0, duration=20.0)
    write_bag(tmp_path / "bag", with_stamps(imu, np.zeros(len(imu))), receive_t=imu.t)
    assert main(["fit", str(tmp_path / "bag"), "--model", "WN", "--axis", "gyro_x", "--starts", "1",
                 "--out", str(tmp_path / "out")]) == 0
    doc = yaml.safe_load((tmp_path / "out" / "model.yaml").read_text())
    assert any("every header stamp is zero" in n for n in doc["meta"]["notes"])
    assert "note: /imu/data: every header stamp is zero" in capsys.readouterr().err
