"""The sampling period from untrustworthy stamps (issue 12): bursty host stamps, NaN messages, disagreeing clocks.

Each bag is crafted with a known sensor rate and noise; before the fix the median stamp interval was the period
(bursty stamps read as ~500 Hz with every density 55 % low; half the messages NaN read as 50 Hz).
"""

from __future__ import annotations

import re

import numpy as np
import pytest
import yaml
from crafted import ACCEL_N, GYRO_N, bursty_stamps, static_imu, with_stamps

from imu_noise_id.bag.writer import write_bag
from imu_noise_id.cli import main
from imu_noise_id.core.errors import InputError
from imu_noise_id.core.timing import estimate_period

RATE = 99.3


@pytest.fixture(scope="module")
def sensor():
    return static_imu(rate=RATE, duration=120.0)


def _analyze(bag, out, *extra) -> tuple[int, dict | None]:
    code = main(["analyze", str(bag), "--model", "none", "--out", str(out), *extra])
    path = out / "imu.yaml"
    return code, (yaml.safe_load(path.read_text()) if code == 0 else None)


def _densities_ok(doc: dict) -> None:
    np.testing.assert_allclose(doc["gyroscope_noise_density_xyz"], GYRO_N, rtol=0.05)
    np.testing.assert_allclose(doc["accelerometer_noise_density_xyz"], ACCEL_N, rtol=0.05)


def test_bursty_host_stamps_give_the_sensor_rate_and_right_densities(tmp_path, sensor, capsys):
    """The issue's MPU-6050 record: bursty host stamps and an uncalibrated accelerometer reading |a| 3.7 % above g
    (refused as not static before; a note now)."""
    t = bursty_stamps(sensor.t)
    assert 1 / np.median(np.diff(t)) > 450  # what the median interval says
    uncalibrated = with_stamps(sensor, t)
    uncalibrated.accel = sensor.accel * 1.037
    write_bag(tmp_path / "bag", uncalibrated, receive_t=t + 5e-4)
    code, doc = _analyze(tmp_path / "bag", tmp_path / "out")
    assert code == 0
    assert doc["update_rate"] == pytest.approx(RATE, rel=1e-3)
    assert doc["update_rate_trusted"] is False and "regression of stamp on message index" in doc["update_rate_source"]
    np.testing.assert_allclose(doc["gyroscope_noise_density_xyz"], GYRO_N, rtol=0.05)
    np.testing.assert_allclose(doc["accelerometer_noise_density_xyz"], 1.037 * ACCEL_N, rtol=0.05)
    captured = capsys.readouterr()
    assert "+3.7 % from standard gravity" in captured.err
    assert "stamps are bursty" in captured.err and "--rate HZ" in captured.err and "!! sample rate" in captured.out
    assert "# WARNING (update_rate): stamps are bursty" in (tmp_path / "out" / "imu.yaml").read_text()


def test_bursty_stamps_and_disagreeing_receive_times_are_refused_until_the_rate_is_given(tmp_path, sensor, capsys):
    t = bursty_stamps(sensor.t)
    receive = t[0] + (t - t[0]) * 1.05  # the recorder's clock says 94.6 Hz
    write_bag(tmp_path / "bag", with_stamps(sensor, t), receive_t=receive)
    code, _ = _analyze(tmp_path / "bag", tmp_path / "out")
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert "'/imu/data'" in err and "receive times" in err and "pass --rate HZ" in err
    assert not (tmp_path / "out" / "imu.yaml").exists()
    code, doc = _analyze(tmp_path / "bag", tmp_path / "out", "--rate", str(RATE))
    assert code == 0 and doc["update_rate"] == pytest.approx(RATE) and "declared" in doc["update_rate_source"]
    _densities_ok(doc)


def test_half_the_messages_nan_keep_the_sensor_rate(tmp_path, capsys):
    imu = static_imu(rate=100.0, duration=120.0)
    imu.gyro[1::2, 0] = np.nan  # every other message unusable
    write_bag(tmp_path / "bag", imu)
    code, doc = _analyze(tmp_path / "bag", tmp_path / "out")
    assert code == 0 and doc["update_rate"] == pytest.approx(100.0, rel=1e-4) and doc["update_rate_trusted"]
    _densities_ok(doc)
    err = capsys.readouterr().err
    assert "50.0 % of the record at 100 Hz) are missing" in err and "1.41x too large" in err


def test_inspect_names_how_the_rate_was_found(tmp_path, sensor, capsys):
    t = bursty_stamps(sensor.t)
    write_bag(tmp_path / "bag", with_stamps(sensor, t))
    assert main(["inspect", str(tmp_path / "bag")]) == 0
    out = capsys.readouterr().out
    found = re.search(r"rate ([0-9.]+) Hz from the regression of stamp on message index", out)
    assert found and float(found.group(1)) == pytest.approx(RATE, rel=2e-3)
    assert "stamps are bursty" in out


# --- the rule itself ---------------------------------------------------------------------------------------------


def test_regular_stamps_keep_the_median_interval_even_with_lost_messages():
    rng = np.random.default_rng(0)
    t = 1.7e9 + 0.0025 * np.arange(40000)
    p = estimate_period(t)
    assert p.source == "median_interval" and p.trusted and p.value == pytest.approx(0.0025, rel=1e-4)
    kept = t[rng.random(t.size) > 0.3]  # 30 % lost in transport, no positions to tell
    p = estimate_period(kept)
    assert p.source == "median_interval" and p.trusted and p.value == pytest.approx(0.0025, rel=1e-4)
    assert 1 / p.estimates["span_count"] == pytest.approx(0.7 * 400, rel=0.02)  # what span/count would say
    jittered = t + rng.normal(0.0, 2.5e-4, t.size)  # 10 % Gaussian jitter: not bursty
    p = estimate_period(jittered)
    assert not p.bursty and p.value == pytest.approx(0.0025, rel=0.01)


def test_stamps_since_1970_give_the_period_below_their_float_step():
    """Stamps since 1970 in float64 seconds are rounded to 2.4e-7 s, so neighbour intervals of a 200 Hz record take
    only the values 20971 or 20972 such steps and their median read 199.995 Hz (25 ppm off; what imu.yaml's
    update_rate said for every real bag). The mean of the intervals around the median is not bound to the step."""
    rng = np.random.default_rng(1)
    t = 1_733_600_000.0 + 0.005 * np.arange(12_000)
    assert np.spacing(t[-1]) == pytest.approx(2.4e-7, rel=0.01)
    assert estimate_period(t).value == pytest.approx(0.005, rel=1e-7)
    kept = np.sort(t[rng.random(t.size) > 0.3])  # lost messages, no positions: the single steps' median
    assert estimate_period(kept).value == pytest.approx(0.005, rel=1e-7)
    assert estimate_period(0.005 * np.arange(12_000)).value == pytest.approx(0.005, rel=1e-12)  # stamps from 0


def test_positions_account_for_dropped_messages():
    t = 1.7e9 + 0.01 * np.arange(10000)
    index = np.arange(0, 10000, 2)
    assert estimate_period(t[index], index=index).value == pytest.approx(0.01, rel=1e-5)
    assert estimate_period(t[index]).value == pytest.approx(0.02, rel=1e-5)  # without positions: what is seen


def test_declared_rate_wins_and_disagreement_is_said():
    t = 1.7e9 + 0.01 * np.arange(5000)
    p = estimate_period(t, declared_hz=100.0)
    assert p.source == "declared" and p.trusted and p.value == 0.01
    p = estimate_period(t, declared_hz=104.0)
    assert p.value == pytest.approx(1 / 104) and "--rate 104 Hz is used although the stamps say 100 Hz" in p.warnings[0]
    with pytest.raises(InputError, match="--rate must be a positive number"):
        estimate_period(t, declared_hz=float("nan"))


def test_a_rate_change_within_the_record_is_warned_about():
    t = np.concatenate([0.01 * np.arange(3000), 30.0 + 0.005 * np.arange(1, 6001)])
    p = estimate_period(t)
    assert any(w.startswith("the rate changes within the record") for w in p.warnings)


def test_receive_times_that_disagree_with_regular_stamps_are_only_a_note():
    t = 1.7e9 + 0.01 * np.arange(5000)
    p = estimate_period(t, receive=t[0] + 0.5 * (t - t[0]))  # a bag re-recorded while played at 2x
    assert p.trusted and p.value == pytest.approx(0.01) and "receive times run at 200 Hz" in p.notes[0]
