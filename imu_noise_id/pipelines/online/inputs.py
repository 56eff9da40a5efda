"""The inputs of the online identification: receive book-keeping and the value and stamp checks
(:class:`~.stamps.StampChecker`), done once per message; :class:`SaturationCheck` flags full-scale IMU samples."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from ...core.axes import AXES
from .config import OnlineConfig
from .events import EventLog
from .stamps import RELEARN_COUNT, StampChecker


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


class Input:
    """One input stream: its counters, its stamp checker and the checks every message passes.

    Parameters
    ----------
    what : ``imu``, ``odom`` or ``temperature``; config : gap factor, backward-reset count; events : problems go there.
    """

    def __init__(self, what: str, config: OnlineConfig, events: EventLog) -> None:
        self.what = what
        self.stats = InputStats()
        self.stamps = StampChecker(config.gap_factor, config.backward_reset_count)
        self._events = events
        self._held: tuple[float, Any] | None = None

    def configure(self, config: OnlineConfig) -> None:
        """Apply changed parameters."""
        self.stamps.gap_factor = config.gap_factor
        self.stamps.backward_reset_count = config.backward_reset_count

    def receive(self, t: float, finite: bool, frame_id: str, wall_time: float | None, nonfinite: str, *,
                payload: Any = None) -> list[tuple[str, Any]]:
        """Checks of one message stamped ``t`` [s] at ``wall_time`` (steady clock); ``finite``: its values are usable
        (``nonfinite`` names what is not). ``(verdict, payload)`` pairs to process now, in stamp order."""
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
            return []
        verdict, held_verdict = self.stamps.check(t)
        out = []
        if held_verdict is not None:
            held_t, held_payload = self._held
            self._held = None
            self._report(held_verdict, held_t)
            if held_verdict != "outlier":
                stats.accepted += 1
                out.append((held_verdict, held_payload))
        if verdict == "hold":
            self._held = (t, payload)
            return out
        if verdict == "restart":
            self._held = None  # a message held on the old time line is forgotten with it
        if verdict != "ok":
            self._report(verdict, t)
        if verdict in ("ok", "relearn", "restart"):
            stats.accepted += 1
            out.append((verdict, payload))
        return out

    def _report(self, verdict: str, t: float) -> None:
        """Count and describe one stamp verdict other than ``ok``."""
        what = self.what
        key = f"{what}_{verdict}"
        self._events.count(key)
        if verdict == "gap":
            self._events.event(key, f"{what}: gap in header stamps before t = {t:.6f} s")
        elif verdict == "relearn":
            self._events.event(key, f"{what}: {RELEARN_COUNT} equal gaps in a row: the rate is now "
                                    f"{self.stamps.rate:.4g} Hz")
        elif verdict == "restart":
            self._events.event(key, f"{what}: stamps jumped back to t = {t:.6f} s and went on from there: a new "
                                    "time line (what was identified is kept)")
        elif verdict == "outlier":
            self._events.event(key, f"{what}: message dropped, its stamp {t!r} jumped away from its neighbours' "
                                    "and back (an isolated outlier)")
        else:
            self._events.event(key, f"{what}: message dropped ({verdict.replace('_', ' ')} stamp {t!r})")


class SaturationCheck:
    """Flags IMU samples at the sensor's full scale: within 0.5 % of a declared ``imu_range.*``, or without one, a
    repeated extreme magnitude of its axis above :data:`FLOOR` (125 °/s, 2 g)."""

    #: Smallest magnitude that can be a full scale without a declared range: gyro [rad/s], accelerometer [m/s²].
    FLOOR = (2.0, 19.0)
    #: A sample within this fraction of a declared range is saturated.
    MARGIN = 0.995

    def __init__(self, config: OnlineConfig) -> None:
        self.configure(config)
        self._extreme = [0.0] * 6
        self._hits = [0] * 6

    def configure(self, config: OnlineConfig) -> None:
        """Apply changed parameters."""
        self._range = [config.imu_range_gyro] * 3 + [config.imu_range_accel] * 3
        self._floor = [self.FLOOR[0]] * 3 + [self.FLOOR[1]] * 3

    def check(self, sample: Sequence[float]) -> list[str]:
        """The :data:`~imu_noise_id.core.axes.AXES` names on which this sample is saturated (plain floats)."""
        out = []
        extreme, hits = self._extreme, self._hits
        for i in range(6):
            a = abs(sample[i])
            if a > extreme[i]:
                extreme[i], hits[i] = a, 1
            elif a == extreme[i]:
                hits[i] += 1
            limit = self._range[i]
            if (a >= self.MARGIN * limit) if limit > 0 else (a == extreme[i] and hits[i] >= 2 and a >= self._floor[i]):
                out.append(AXES[i])
        return out
