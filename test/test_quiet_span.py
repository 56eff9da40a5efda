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
