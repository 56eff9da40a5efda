"""The node's input checks must not be poisoned or locked by one bad message (issue 12, node part)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imu_noise_id.core.quality import IMU_MAX_ABS
from imu_noise_id.pipelines.online import OnlineIdentifier
from imu_noise_id.pipelines.online.stamps import RELEARN_COUNT, StampChecker


@pytest.mark.parametrize("absurd", [1e10, 1e300, -3.5e3])
def test_an_absurd_but_finite_sample_is_rejected_like_the_offline_reader_does(absurd):
    ident = OnlineIdentifier()
    rng = np.random.default_rng(0)
    for k in range(200):
        ident.process_imu(0.01 * (k + 1), tuple(rng.normal(0, 1e-3, 3)), (0.0, 0.0, 9.81 + rng.normal(0, 1e-2)))
    accepted = ident.imu.stats.accepted
    assert ident.process_imu(2.01, (absurd, 0.0, 0.0), (0.0, 0.0, 9.81)) == []
    assert ident.process_imu(2.02, (0.0, 0.0, 0.0), (0.0, 0.0, 1e5)) == []
    assert ident.imu.stats.accepted == accepted and ident.imu.stats.rejected_values == 2
    assert abs(absurd) > IMU_MAX_ABS[0]
    # and the stream goes on
    assert len(ident.process_imu(2.03, (0.0, 0.0, 0.0), (0.0, 0.0, 9.81))) == 1


def _verdicts(checker: StampChecker, stamps) -> list[str]:
    """The verdict of every stamp, once known (a held stamp's is the one the next stamp settled)."""
    out = []
    for t in stamps:
        verdict, held = checker.check(t)
        if held is not None:
            out[-1] = held
        out.append(verdict)
    return out


def test_a_tiny_first_interval_does_not_make_every_later_message_a_gap():
    """Host-stamped serial drivers: the first two messages 1 µs apart, then 100 Hz."""
    c = StampChecker(gap_factor=10.0)
    stamps = [1.0, 1.000001, *(1.000001 + 0.01 * np.arange(1, 300))]
    v = _verdicts(c, stamps)
    assert v[-100:] == ["ok"] * 100, v[:40]
    assert v.count("gap") <= RELEARN_COUNT
    assert c.rate == pytest.approx(100.0, rel=0.05)


def test_a_rate_drop_is_relearned():
    c = StampChecker(gap_factor=10.0)
    stamps = [*(0.01 * np.arange(1, 200)), *(2.0 + 0.2 * np.arange(1, 100))]  # 100 Hz, then 5 Hz
    v = _verdicts(c, stamps)
    assert v[-50:] == ["ok"] * 50 and c.rate == pytest.approx(5.0, rel=0.05)


def test_a_single_gap_is_still_a_gap():
    c = StampChecker(gap_factor=10.0)
    v = _verdicts(c, [*(0.01 * np.arange(1, 100)), 5.0, *(5.0 + 0.01 * np.arange(1, 50))])
    assert v.count("gap") == 1 and c.rate == pytest.approx(100.0, rel=0.01) and not math.isnan(c.rate)


def _feed_still(ident: OnlineIdentifier, n: int, t0: float = 0.0, wall0: float = 0.0, frame: str = "imu") -> None:
    rng = np.random.default_rng(1)
    for k in range(n):
        ident.process_imu(t0 + 0.01 * (k + 1), tuple(rng.normal(0, 1e-3, 3)),
                          (0.0, 0.0, 9.81 + rng.normal(0, 1e-2)), frame, wall0 + 0.01 * (k + 1))


def _status(statuses, name):
    return next(s for s in statuses if s.name == name)


def test_diagnostics_do_not_contradict_themselves():
    """'OK IMU input: 0.0 Hz' after the input stopped, 'identification running' while the IMU is stale, p99 nan,
    and a frame_id WARN that never clears."""
    from imu_noise_id.pipelines.online import OK, STALE, WARN

    ident = OnlineIdentifier()
    diag = ident.diagnostics(wall_now=0.0, window_s=1.0)
    assert "nan" not in _status(diag, "Processing").message
    _feed_still(ident, 3000)  # 30 s still at 100 Hz
    first = ident.diagnostics(wall_now=30.0, window_s=30.0)
    assert _status(first, "IMU input").level == OK
    # the input stops: in the next period nothing arrives, but the stale timeout is not reached yet
    quiet = ident.diagnostics(wall_now=30.9, window_s=0.9)
    imu = _status(quiet, "IMU input")
    assert imu.level != OK or "0.0 Hz" not in imu.message
    stale = ident.diagnostics(wall_now=60.0, window_s=29.1)
    assert _status(stale, "IMU input").level == STALE
    assert "identification running" not in _status(stale, "Stationarity").message
    # one frame_id change warns in its period and clears afterwards
    _feed_still(ident, 100, t0=30.0, wall0=60.0, frame="imu2")
    assert _status(ident.diagnostics(wall_now=61.0, window_s=1.0), "IMU input").level == WARN
    _feed_still(ident, 100, t0=31.0, wall0=61.0, frame="imu2")
    assert _status(ident.diagnostics(wall_now=62.0, window_s=1.0), "IMU input").level == OK


def test_a_decision_is_held_until_its_probability_falls_clearly_below_gamma():
    """WN+RW ↔ undecided flapped five times in the demo at γ = 0.8 with p hovering around 0.8."""
    from imu_noise_id.pipelines.online.bank import held_decision

    decision, changes = None, 0
    for p in (0.75, 0.81, 0.79, 0.80, 0.78, 0.82, 0.76, 0.81):  # hovering at γ
        new = held_decision(decision, {"WN+RW": p, "WN+GM": 1 - p}, 0.8)
        changes += new != decision
        decision = new
    assert decision == "WN+RW" and changes == 1
    assert held_decision("WN+RW", {"WN+RW": 0.65, "WN+GM": 0.35}, 0.8) is None
    assert held_decision("WN+RW", {"WN+RW": 0.15, "WN+GM": 0.85}, 0.8) == "WN+GM"
