"""The online watch of an IMU against its reference (an earlier ``analyze``) and datasheet limits (docs/node.md):
stationary samples run ``SequentialNoiseWatch`` CUSUMs against the reference (both ways; ``AllanWatch``: the same at
τ = 1 and 10 s), its bias-step and new-line tests on a sliding window (``WindowedChecks``), and each sensor's density
limit (upwards, v₀ = the reference's shape at the limit, v₁ = ``LIMIT_RATIO``² v₀; without a reference white
noise); in motion the CMKF's density intervals are held against the reference's. Status per sensor: OK, WARN (left
its reference: how much, since when; a bias step, a new line; in motion beyond it), ERROR (beyond the spec, or the
watch cannot run). It starts once the IMU's period is known."""

from __future__ import annotations

import math

import numpy as np

from ...core.axes import AXES, SENSORS, sensor_of
from ...core.watch.allan_watch import AllanWatch
from ...core.watch.axis_reference import AxisReference, rate_mismatch
from ...core.watch.noise_level import LIMIT_RATIO, per_test
from ...core.watch.sequential import AxisWatch, SequentialNoiseWatch
from ...core.watch.windowed import WindowedChecks, WindowFinding
from .status import ERROR, OK, WARN, DiagnosticStatus


class ReferenceWatch:
    """The watch of every axis against ``references`` (by axis) made at ``rate_hz`` [Hz] from ``source``, and against
    ``limits`` (noise density [u/√Hz] per sensor, "gyro"/"accel", from ``limits_source``), at
    ``false_alarms_per_hour`` for the whole IMU (shared among its axes and tests, ``noise_level.per_test``); with
    ``error`` (the reference or the limits could not be read) it only reports that. ``references`` None with
    ``limits``: the limits alone (their white noise as the reference shape, at any rate)."""

    def __init__(self, references: dict[str, AxisReference] | None, rate_hz: float, source: str, *, ratio: float,
                 false_alarms_per_hour: float, error: str | None = None, limits: dict[str, float] | None = None,
                 limits_source: str = "") -> None:
        self.references, self.rate_hz, self.source = references, rate_hz, source
        self.ratio = ratio
        self.false_alarms_per_hour = per_test(false_alarms_per_hour, len(AXES))  # of one test of one axis
        self.limits, self.limits_source = dict(limits or {}), limits_source
        self.refused = error
        self.watch: SequentialNoiseWatch | None = None
        self.spec_watch: SequentialNoiseWatch | None = None
        self.windowed: WindowedChecks | None = None
        self.allan: AllanWatch | None = None

    def _start(self, period: float) -> None:
        """Both watches at the IMU's ``period`` [s] (the reference's rate checked first)."""
        if self.references is not None:
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
            self.windowed = WindowedChecks([self.references[axis] for axis in AXES], period,
                                           false_alarms_per_hour=self.false_alarms_per_hour)
            self.allan = AllanWatch([self.references[axis] for axis in AXES], period, ratio=self.ratio,
                                    false_alarms_per_hour=self.false_alarms_per_hour)
        if self.limits:
            v_spec = []
            for axis in AXES:
                limit = self.limits.get(sensor_of(axis))
                if limit is None:  # a sensor without a limit: its CUSUMs run, and are never read (beyond_spec)
                    v_spec.append(1.0)
                    continue
                shape = self.references[axis] if self.references is not None else AxisReference(
                    limit, (math.nan, math.nan))
                v_spec.append(shape.difference_variance_at(limit, period))
            # the interval (0, v): the upward CUSUM only (an axis quieter than its limit is no finding)
            self.spec_watch = SequentialNoiseWatch(v_spec, [(0.0, v) for v in v_spec], period, ratio=LIMIT_RATIO,
                                                   false_alarms_per_hour=self.false_alarms_per_hour, least_change=1.0)

    def add(self, t: float, sample, period: float | None) -> None:
        """A stationary sample (AXES order) at stamp ``t`` [s], the IMU's period [s] (None while unknown)."""
        if self.refused is not None or period is None:
            return
        if self.watch is None and self.spec_watch is None:
            self._start(period)
            if self.refused is not None:
                return
        for watch in (self.watch, self.spec_watch, self.windowed, self.allan):
            if watch is not None:
                watch.add(t, sample)

    def break_chain(self) -> None:
        for watch in (self.watch, self.spec_watch, self.windowed, self.allan):
            if watch is not None:
                watch.break_chain()

    def in_motion(self, density_ci: np.ndarray) -> dict[str, tuple[float, float]]:
        """The axes whose density interval from the CMKF's innovations ``density_ci`` ((6, 2) [u/√Hz], AXES order;
        NaN where not identified) lies beyond the reference's interval by more than ``ratio`` (either way), with that
        interval as ratios to the reference's N. Not latched: it follows the CMKF's estimate, which in motion also
        holds what the platform adds (vibration), so it is a warning, never a spec ERROR."""
        if self.references is None or self.refused is not None:
            return {}
        out = {}
        for axis, (lo, hi) in zip(AXES, np.asarray(density_ci, dtype=float), strict=True):
            reference = self.references[axis]
            (ref_lo, ref_hi), _ = reference.density_interval()
            if np.isfinite(lo) and np.isfinite(hi) and (lo > self.ratio * ref_hi or hi < ref_lo / self.ratio):
                out[axis] = (lo / reference.noise_density, hi / reference.noise_density)
        return out

    def changes(self) -> dict[str, dict[str, WindowFinding]]:
        """The bias steps and new lines found per axis ({"step": …, "line": …}; axes without one left out)."""
        if self.windowed is None:
            return {}
        return {axis: found for axis, found in zip(AXES, self.windowed.findings, strict=True) if found}

    def axes(self) -> dict[str, AxisWatch]:
        """Every axis's state against its reference (empty before the watch started or without a reference)."""
        return {} if self.watch is None else {axis: self.watch.axis(i) for i, axis in enumerate(AXES)}

    def beyond_spec(self) -> dict[str, AxisWatch]:
        """The axes whose density the specification's CUSUM found beyond its limit (the level since confirming it),
        their state against it."""
        if self.spec_watch is None:
            return {}
        out = {}
        for i, axis in enumerate(AXES):
            state = self.spec_watch.axis(i)
            if sensor_of(axis) in self.limits and state.confirmed_s is not None:
                out[axis] = state
        return out

    def statuses(self, cmkf_density_ci: np.ndarray | None = None) -> list[DiagnosticStatus]:
        """One status per sensor (module docstring); with ``cmkf_density_ci`` ((6, 2) [u/√Hz], the CMKF's density
        intervals) also :meth:`in_motion`'s axes, as WARN."""
        out = []
        states, beyond, changes = self.axes(), self.beyond_spec(), self.changes()
        moving = {} if cmkf_density_ci is None else self.in_motion(cmkf_density_ci)
        sources = {"reference": self.source} if self.references is not None else {}
        if self.limits:
            sources["spec"] = self.limits_source
        for sensor, axes in SENSORS:
            name = f"Reference watch ({sensor})"
            if self.refused is not None:
                out.append(DiagnosticStatus(name, ERROR, f"not watching: {self.refused}", dict(sources)))
                continue
            started = self.watch is not None or self.spec_watch is not None
            if not started and not any(axis in moving for axis in axes):
                out.append(DiagnosticStatus(name, OK, "waiting for stationary samples", dict(sources)))
                continue
            values = dict(sources)
            if started:
                values["pairs"] = str((self.watch or self.spec_watch).pairs)
            alarms, errors, transients = [], [], []
            for axis in axes:
                if axis in states:
                    s = states[axis]
                    values[f"{axis}_density_ratio"] = f"{s.ratio:.3g}"
                    if s.confirmed_s is not None:
                        values[f"{axis}_since"] = f"{s.alarm.since_s:.3f}"
                        alarms.append(f"{axis} noise {s.alarm.direction} ({s.since_ratio:.3g}× the reference since "
                                      f"then) since stamp {s.alarm.since_s:.1f} s")
                    if s.transient is not None:
                        values[f"{axis}_transient_at"] = f"{s.transient.since_s:.3f}"
                        transients.append(f"{axis}: a transient of {s.transient.direction}ward noise at stamp "
                                          f"{s.transient.since_s:.1f} s, the level after it {s.transient_ratio:.3g}×")
                for tau, state in ({} if self.allan is None else self.allan.axis(AXES.index(axis))).items():
                    key = f"{axis}_adev_ratio_tau{tau:g}s"
                    values[key] = f"{state.ratio:.3g}"
                    if state.confirmed_s is not None:
                        alarms.append(f"{axis} Allan deviation at {tau:g} s {state.alarm.direction} "
                                      f"({state.since_ratio:.3g}× the reference since then) since stamp "
                                      f"{state.alarm.since_s:.1f} s")
                    if state.transient is not None:
                        transients.append(f"{axis}: a transient of {state.transient.direction}ward Allan deviation "
                                          f"at {tau:g} s at stamp {state.transient.since_s:.1f} s")
                step, line = changes.get(axis, {}).get("step"), changes.get(axis, {}).get("line")
                if step is not None:
                    values[f"{axis}_bias_step"] = f"{step.value:.3g}"
                    values[f"{axis}_bias_step_since"] = f"{step.since_s:.3f}"
                    alarms.append(f"{axis} bias step of {step.value:.3g} at stamp {step.since_s:.1f} s")
                if line is not None:
                    values[f"{axis}_new_line_hz"] = f"{line.value:.5g}"
                    alarms.append(f"{axis} new line at {line.value:.4g} Hz (amplitude {line.amplitude:.3g}) by stamp "
                                  f"{line.time_s:.1f} s")
                if axis in moving:
                    lo, hi = moving[axis]
                    values[f"{axis}_motion_density_ratio"] = f"{lo:.3g}..{hi:.3g}"
                    alarms.append(f"{axis} in motion: the CMKF's density is [{lo:.3g}, {hi:.3g}]× the reference "
                                  "(its innovations; platform vibration included)")
                limit = self.limits.get(sensor_of(axis))
                if limit is not None and self.spec_watch is not None:
                    spec_state = self.spec_watch.axis(AXES.index(axis))
                    values[f"{axis}_spec_ratio"] = f"{spec_state.ratio:.3g}"
                    if axis in beyond:
                        values[f"{axis}_beyond_spec_since"] = f"{beyond[axis].alarm.since_s:.3f}"
                        errors.append(f"{axis} noise beyond the spec ({spec_state.ratio:.3g}× its limit "
                                      f"{limit:.3g}) since stamp {beyond[axis].alarm.since_s:.1f} s")
            if errors:
                out.append(DiagnosticStatus(name, ERROR, "; ".join(errors + alarms), values))
            elif alarms:
                out.append(DiagnosticStatus(name, WARN, "; ".join(alarms), values))
            elif self.watch is not None:
                out.append(DiagnosticStatus(name, OK, "within the reference (density ratio " + ", ".join(
                    f"{states[a].ratio:.3g}" for a in axes) + ")" + "".join(f"; {t}" for t in transients), values))
            else:
                out.append(DiagnosticStatus(name, OK, "within the spec", values))
        return out
