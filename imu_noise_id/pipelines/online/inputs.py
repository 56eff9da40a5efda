"""The inputs of the online identification: receive book-keeping and the value and stamp checks, done once.

Every input message (IMU, odometry, temperature) passes :meth:`Input.receive`: it is counted (``received``, per
diagnostics period, arrival time on the steady clock, frame changes), its values must be finite and its header
stamp usable (:class:`StampChecker`); a rejected message is counted, reported as an event, and goes no further.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...core.axes import AXES
from .config import OnlineConfig
from .events import EventLog


@dataclass
class InputStats:
    """Counters of one input stream; ``received`` and ``accepted`` grow forever, the window ones are reset."""

    received: int = 0
    accepted: int = 0
    rejected_values: int = 0
    window_received: int = 0
    last_wall: float | None = None
    frame_id: str | None = None
    frame_changes: int = 0
    window_frame_changes: int = 0
    saturated: int = 0
    window_saturated: int = 0


@dataclass
class StampChecker:
    """Header-stamp checks for one input stream.

    ``check(t)`` returns ``"ok"``, ``"gap"`` (accepted, after a period longer than ``gap_factor`` × the
    nominal period), ``"relearn"`` (accepted: :data:`RELEARN_COUNT` gaps in a row of nearly equal length are the
    new rate, not gaps — a rate change, or a nominal period learnt from a burst or a first interval of a
    microsecond), ``"restart"`` (accepted: ``backward_reset_count`` consecutive backward stamps mean the source
    restarted), or the reason for rejecting the message: ``"bad_stamp"`` (zero or not finite), ``"duplicate"`` or
    ``"backward"``.
    """

    #: Consecutive gaps of nearly equal length (within a factor :data:`RELEARN_SPREAD`) that set a new period.
    RELEARN_COUNT = 10
    RELEARN_SPREAD = 2.0

    gap_factor: float = 10.0
    backward_reset_count: int = 50
    last: float | None = None
    period: float | None = None
    consecutive_backward: int = 0
    gap_run: list[float] = field(default_factory=list)
    counts: dict[str, int] = field(
        default_factory=lambda: dict.fromkeys(("ok", "gap", "relearn", "restart", "bad_stamp", "duplicate",
                                               "backward"), 0)
    )

    def check(self, t: float) -> str:
        verdict = self._verdict(t)
        self.counts[verdict] += 1
        return verdict

    def _verdict(self, t: float) -> str:  # noqa: PLR0911 - one return per verdict
        if not math.isfinite(t) or t <= 0.0:
            return "bad_stamp"
        last = self.last
        if last is None:
            self.last = t
            return "ok"
        dt = t - last
        if dt == 0.0:
            return "duplicate"
        if dt < 0.0:
            self.consecutive_backward += 1
            if self.consecutive_backward >= self.backward_reset_count:
                self.consecutive_backward = 0
                self.last = t
                self.period = None
                return "restart"
            return "backward"
        self.consecutive_backward = 0
        self.last = t
        period = self.period
        if period is None:
            self.period = dt
            return "ok"
        if dt > self.gap_factor * period:
            self.gap_run.append(dt)
            if len(self.gap_run) < self.RELEARN_COUNT:
                return "gap"
            run = self.gap_run[-self.RELEARN_COUNT:]
            if max(run) > self.RELEARN_SPREAD * min(run):
                return "gap"
            self.period = float(sorted(run)[len(run) // 2])
            self.gap_run.clear()
            return "relearn"
        self.gap_run.clear()
        self.period = period + 0.01 * (dt - period)
        return "ok"

    @property
    def rate(self) -> float:
        """Nominal rate from the header stamps [Hz] (NaN until two stamps were seen)."""
        return 1.0 / self.period if self.period else math.nan


class Input:
    """One input stream: its counters, its stamp checker and the checks every message passes.

    Parameters
    ----------
    what : the stream's name in events and counts (``imu``, ``odom``, ``temperature``).
    config : the gap factor and the backward-reset count of the stamp checks.
    events : where rejected messages and stamp problems are reported.
    """

    #: Stamp verdicts that make a message unusable.
    UNUSABLE = ("bad_stamp", "duplicate", "backward")

    def __init__(self, what: str, config: OnlineConfig, events: EventLog) -> None:
        self.what = what
        self.stats = InputStats()
        self.stamps = StampChecker(config.gap_factor, config.backward_reset_count)
        self._events = events

    def configure(self, config: OnlineConfig) -> None:
        """Apply changed parameters."""
        self.stamps.gap_factor = config.gap_factor
        self.stamps.backward_reset_count = config.backward_reset_count

    def receive(self, t: float, finite: bool, frame_id: str, wall_time: float | None, nonfinite: str) -> str | None:
        """Book-keeping and checks of one message stamped ``t`` [s] that arrived at ``wall_time`` (steady clock).

        ``finite`` says whether its values are all finite and plausible; ``nonfinite`` names what is not, for the
        event.
        Returns the stamp verdict of an accepted message (``ok``, ``gap``, ``restart``), or None when the message
        is rejected (non-finite values, zero, non-finite, duplicated or backward stamp), counted and reported.
        """
        what, stats = self.what, self.stats
        stats.received += 1
        stats.window_received += 1
        stats.last_wall = wall_time
        if stats.frame_id != frame_id:
            if stats.frame_id is not None:
                stats.frame_changes += 1
                stats.window_frame_changes += 1
                self._events.event(f"{what}_frame", f"{what} frame_id changed from {stats.frame_id!r} to {frame_id!r}")
            stats.frame_id = frame_id
        if not finite:
            stats.rejected_values += 1
            self._events.count(f"{what}_nonfinite")
            self._events.event(f"{what}_nonfinite", f"{what}: message with non-finite {nonfinite} at t = {t!r}")
            return None
        verdict = self.stamps.check(t)
        if verdict != "ok":
            key = f"{what}_{verdict}"
            self._events.count(key)
            if verdict == "gap":
                self._events.event(key, f"{what}: gap in header stamps before t = {t:.6f} s")
            elif verdict == "relearn":
                self._events.event(key, f"{what}: {self.stamps.RELEARN_COUNT} equal gaps in a row: the rate is "
                                        f"now {self.stamps.rate:.4g} Hz")
            elif verdict == "restart":
                self._events.event(key, f"{what}: stamps jumped back to t = {t:.6f} s and stayed there: restarting")
            else:
                self._events.event(key, f"{what}: message dropped ({verdict.replace('_', ' ')} stamp {t!r})")
        if verdict in self.UNUSABLE:
            return None
        stats.accepted += 1
        return verdict


class SaturationCheck:
    """Flags IMU samples at the sensor's full scale (a bump or a fast turn clipped by the sensor).

    With a declared range (``imu_range.gyro``, ``imu_range.accel``) a sample within 0.5 % of it is saturated.
    Without, a clipped sensor shows itself by repeating one value at its extreme: a sample whose magnitude equals
    the largest one seen on its axis, seen at least twice, and above :data:`FLOOR` (below the smallest common full
    scales, 125 °/s and 2 g, a repeated extreme is ordinary quantisation) is flagged as saturated.
    """

    #: Smallest magnitude that can be a full scale without a declared range: gyro [rad/s], accelerometer [m/s²].
    FLOOR = (2.0, 19.0)
    #: A sample within this fraction of a declared range is saturated.
    MARGIN = 0.995

    def __init__(self, config: OnlineConfig) -> None:
        self.configure(config)
        self._extreme = np.zeros(6)
        self._hits = np.zeros(6, dtype=int)

    def configure(self, config: OnlineConfig) -> None:
        """Apply changed parameters."""
        self._range = np.repeat([config.imu_range_gyro, config.imu_range_accel], 3)
        self._floor = np.repeat(self.FLOOR, 3)

    def check(self, sample: np.ndarray) -> list[str]:
        """The axes (names of :data:`~imu_noise_id.core.axes.AXES`) on which this sample is saturated."""
        a = np.abs(sample)
        higher = a > self._extreme
        self._extreme = np.where(higher, a, self._extreme)
        self._hits = np.where(higher, 1, self._hits + (a == self._extreme))
        declared = self._range > 0
        flagged = np.where(declared, a >= self.MARGIN * self._range,
                           (a == self._extreme) & (self._hits >= 2) & (a >= self._floor))
        return [AXES[i] for i in np.flatnonzero(flagged)]
