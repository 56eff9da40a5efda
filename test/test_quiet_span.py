"""A record that moves for most of its length is refused with its longest quiet stretch as the span to take (the
demo robot stands 20 s, drives 25 s and stands 20 s); a still record and a record with bursts keep their rules."""

from __future__ import annotations

import numpy as np
import pytest

from imu_noise_id.core.axes import ImuSeries
from imu_noise_id.core.errors import InputError
from imu_noise_id.core.stillness import QUIET_MIN_S, static_check
from imu_noise_id.demo.online import simulate_demo_run
from imu_noise_id.pipelines.analyze.static import analyze_static


@pytest.fixture(scope="module")
def robot() -> ImuSeries:
    run = simulate_demo_run()
    return ImuSeries(run.imu_t, run.gyro, run.accel, topic="/imu/data")


def test_the_robot_record_offers_one_of_its_standing_stretches(robot):
    check = static_check(robot)
    assert check.flags and not check.bursts
    start, end = check.still_span
    assert end - start >= QUIET_MIN_S
    assert end <= 20.0 + 0.5 or start >= 45.0 - 0.5  # inside the stand before or the stand after the drive
    assert static_check(robot.between(start, end)).static
    with pytest.raises(InputError, match=r"--span \d+\.\d:\d+\.\d"):
        analyze_static(robot)


def test_a_record_moving_throughout_offers_no_span(robot):
    moving = robot.between(21.0, 44.0)  # the drive alone
    check = static_check(moving)
    assert check.flags and check.still_span is None


def test_a_still_record_is_not_flagged():
    rng = np.random.default_rng(2)
    n = 20_000
    imu = ImuSeries(np.arange(n) * 0.005, 1e-3 * rng.standard_normal((n, 3)),
                    [0.0, 0.0, 9.81] + 1e-2 * rng.standard_normal((n, 3)))
    check = static_check(imu)
    assert check.static and check.still_span is None


def test_with_bursts_the_span_offered_passes_the_block_tests_and_is_given_from_the_records_first_sample(robot):
    """A knock at 10 s of the robot record (stand 20 s, drive 25 s, stand 20 s): the longest stretch between bursts
    runs through the drive, and was offered unchecked (on a moving robot's bag inspect and analyze offered a span that
    analyze then refused). The span offered now passes the block tests: the stand after the drive. Analysed from 5 s
    on (--span 5:inf), the span offered is given from the record's first sample, as --span reads it."""
    from crafted import touched

    knocked = touched(robot, 10.0, 1.0, gyro=0.5, accel=1.0)
    check = static_check(knocked)
    assert check.bursts and check.still_span is not None
    start, end = check.still_span
    assert start >= 45.0 - 0.5 and end - start >= QUIET_MIN_S
    assert static_check(knocked.between(start, end)).static
    with pytest.raises(InputError) as refused:
        analyze_static(knocked.between(5.0, np.inf), origin_s=5.0)
    offered = [float(v) for v in refused.value.args[0].split("--span ")[-1].rstrip(")").split(":")]
    assert offered == pytest.approx([start, end], abs=0.15)
    assert "5 s into the record" in refused.value.args[0]
