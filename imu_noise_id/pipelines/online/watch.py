"""The online watch of an IMU against its own reference (an earlier ``analyze`` of this unit): the stationary
samples run the noise-level CUSUMs of :class:`~imu_noise_id.core.watch.sequential.SequentialNoiseWatch`, and each
sensor's status is OK (every axis within its reference), WARN (an axis's density left it: by how much and since
when) or ERROR (the reference cannot be used: unreadable, or made at another rate). The watch starts once the IMU's
period is known."""

from __future__ import annotations

from ...core.axes import ACCEL_AXES, AXES, GYRO_AXES
from ...core.watch.compare import AxisReference, rate_mismatch
from ...core.watch.sequential import AxisWatch, SequentialNoiseWatch
from .status import ERROR, OK, WARN, DiagnosticStatus


class ReferenceWatch:
    """The watch of every axis against ``references`` (by axis) made at ``rate_hz`` [Hz] from ``source``; with
    ``error`` (the reference could not be read) it only reports that."""

    def __init__(self, references: dict[str, AxisReference] | None, rate_hz: float, source: str, *, ratio: float,
                 false_alarms_per_hour: float, error: str | None = None) -> None:
        self.references, self.rate_hz, self.source = references or {}, rate_hz, source
        self.ratio, self.false_alarms_per_hour = ratio, false_alarms_per_hour
        self.refused = error
        self.watch: SequentialNoiseWatch | None = None

    def add(self, t: float, sample, period: float | None) -> None:
        """A stationary sample (AXES order) at stamp ``t`` [s], the IMU's period [s] (None while unknown)."""
        if self.refused is not None or period is None:
            return
        if self.watch is None:
            self.refused = rate_mismatch(1.0 / period, self.rate_hz, self.source)
            if self.refused is not None:
                return
            v, intervals = [], []
            for axis in AXES:
                value, interval, _ = self.references[axis].difference_variance(period)
                v.append(value)
                intervals.append(interval)
            self.watch = SequentialNoiseWatch(v, intervals, period, ratio=self.ratio,
                                              false_alarms_per_hour=self.false_alarms_per_hour)
        self.watch.add(t, sample)

    def break_chain(self) -> None:
        if self.watch is not None:
            self.watch.break_chain()

    def axes(self) -> dict[str, AxisWatch]:
        """Every axis's state (empty before the watch started)."""
        return {} if self.watch is None else {axis: self.watch.axis(i) for i, axis in enumerate(AXES)}

    def statuses(self) -> list[DiagnosticStatus]:
        """One status per sensor (module docstring)."""
        out = []
        states = self.axes()
        for sensor, axes in (("gyro", GYRO_AXES), ("accel", ACCEL_AXES)):
            name = f"Reference watch ({sensor})"
            if self.refused is not None:
                out.append(DiagnosticStatus(name, ERROR, f"not watching: {self.refused}", {"reference": self.source}))
                continue
            if not states:
                out.append(DiagnosticStatus(name, OK, "waiting for stationary samples", {"reference": self.source}))
                continue
            values = {"reference": self.source, "pairs": str(states[axes[0]].pairs)}
            alarms = []
            for axis in axes:
                s = states[axis]
                values[f"{axis}_density_ratio"] = f"{s.ratio:.3g}"
                if s.alarm is not None:
                    values[f"{axis}_since"] = f"{s.alarm.since_s:.3f}"
                    alarms.append(f"{axis} noise {s.alarm.direction} ({s.ratio:.3g}× the reference) since stamp "
                                  f"{s.alarm.since_s:.1f} s")
            if alarms:
                out.append(DiagnosticStatus(name, WARN, "; ".join(alarms), values))
            else:
                out.append(DiagnosticStatus(name, OK, "within the reference (density ratio " + ", ".join(
                    f"{states[a].ratio:.3g}" for a in axes) + ")", values))
        return out
