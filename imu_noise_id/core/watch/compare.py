"""One axis of a recording against its reference (docs/analysis.md, "Compare against a reference"): noise level both
ways, the Allan variance at a few τ, and a bias step and a new line in the reference model's innovations, over the
whole record and in the node's windows."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..diagnostics import detectors as det
from ..diagnostics.whitening import WhiteningFilter
from .allan_watch import DEFAULT_TAUS, watch_allan
from .axis_reference import AxisReference
from .innovation_tests import step_and_line
from .noise_level import (
    DEFAULT_FALSE_ALARMS_PER_HOUR,
    DEFAULT_RATIO,
    NoiseLevel,
    beyond_limit,
    watch_noise_level,
)
from .windowed import scan_windows


@dataclass(frozen=True)
class AxisComparison:
    """An axis's outcome: ``noise``, ``step``, ``line`` (the whole record's finding, else the first of the node's
    windows', whose params add ``window_end`` [s]), ``notes``, the spec ``limit`` test, ``allan`` (τ [s] → level
    test)."""

    noise: NoiseLevel
    step: det.Finding | None
    line: det.Finding | None
    alpha: float
    notes: list[str] = field(default_factory=list)
    limit: NoiseLevel | None = None
    allan: dict[float, NoiseLevel] = field(default_factory=dict)

    @property
    def beyond_spec(self) -> bool:
        return self.limit is not None and self.limit.sustained

    @property
    def degraded(self) -> bool:
        return (self.noise.sustained or self.step is not None or self.line is not None or self.beyond_spec
                or any(level.sustained for level in self.allan.values()))

    def findings(self) -> list[str]:
        """What differs from the reference, in words (empty when within)."""
        out = []
        a = self.noise.alarm
        if self.noise.sustained:  # an alarm the level since it holds
            out.append(f"noise {'up' if a.direction == 'up' else 'down'}: density {self.noise.ratio:.3g}× the "
                       f"reference [{self.noise.ratio_ci[0]:.3g}, {self.noise.ratio_ci[1]:.3g}] since "
                       f"{a.since_s:.1f} s (alarm at {a.time_s:.1f} s)")
        for tau, level in self.allan.items():
            if level.sustained:
                out.append(f"Allan deviation at {tau:g} s {level.alarm.direction}: {level.ratio:.3g}× the reference "
                           f"[{level.ratio_ci[0]:.3g}, {level.ratio_ci[1]:.3g}] since {level.alarm.since_s:.1f} s")
        if self.beyond_spec:
            out.append(f"BEYOND THE SPEC: density {self.limit.ratio:.3g}× its limit [{self.limit.ratio_ci[0]:.3g}, "
                       f"{self.limit.ratio_ci[1]:.3g}] since {self.limit.alarm.since_s:.1f} s")
        if self.step is not None:
            p = self.step.params
            out.append(f"bias step of {p['size']:.3g} at {p['time']:.1f} s{_window(p)}")
        if self.line is not None:
            p = self.line.params
            out.append(f"new line at {p['frequency']:.4g} Hz (amplitude {p.get('amplitude', math.nan):.3g})"
                       + (f" from {p['since']:.1f} s{_window(p)}" if "window_end" in p else ""))
        return out


def _window(params: dict[str, float]) -> str:
    """Where a finding of the node's windows was made (empty for the whole record's)."""
    return f" (in the window ending at {params['window_end']:.1f} s)" if "window_end" in params else ""


def compare_axis(y: np.ndarray, dt: float, reference: AxisReference, *, ratio: float = DEFAULT_RATIO,
                 false_alarms_per_hour: float = DEFAULT_FALSE_ALARMS_PER_HOUR,
                 limit: float | None = None) -> AxisComparison:
    """The module's tests on ``y`` [u] at ``dt`` [s], also at ``allan_watch.DEFAULT_TAUS`` and against ``limit``
    [u/√Hz], each at ``false_alarms_per_hour`` λ; ValueError on fewer than 200 samples or a noiseless reference.

    The bias-step and new-line tests share λ: half to the whole record (α = min(0.01, λT/2) for T hours, the most
    power against a change that lasts) and half to the node's windows (:func:`~.windowed.scan_windows`), so that
    ``compare`` finds what the node's watch would on the same data, a change near the record's end included; the
    whole record's finding is kept where both find one."""
    y = np.asarray(y, dtype=float)
    v, interval, note = reference.difference_variance(dt)
    noise = watch_noise_level(y, dt, v, interval, ratio=ratio, false_alarms_per_hour=false_alarms_per_hour)
    hours = y.size * dt / 3600.0
    alpha = min(det.ALPHA, false_alarms_per_hour / 2.0 * hours)
    whitening = WhiteningFilter.from_components(reference.step_model(dt), dt)
    step, line = step_and_line(y, dt, whitening, alpha, reference.known_lines, bands=reference.resonance_bands(dt))
    windows = scan_windows(y, dt, reference, false_alarms_per_hour=false_alarms_per_hour / 2.0)
    step, line = step or windows.get("step"), line or windows.get("line")
    beyond = None if limit is None else beyond_limit(y, dt, reference.difference_variance_at(limit, dt),
                                                     false_alarms_per_hour=false_alarms_per_hour)
    allan = {}
    for tau in DEFAULT_TAUS:
        level = watch_allan(y, dt, reference, tau, ratio=ratio, false_alarms_per_hour=false_alarms_per_hour)
        if level is not None:
            allan[tau] = level
    notes = [note] if note else []
    tests = [(noise, "noise", "the reference"), (beyond, "noise", "its limit")]
    tests += [(level, f"Allan deviation at {tau:g} s", "the reference") for tau, level in allan.items()]
    for level, quantity, what in tests:
        if level is not None and level.alarm is not None and not level.sustained:
            short = f", short of {level.least_change:.3g}×" if level.least_change > 1.0 else ""
            notes.append(f"a transient of {level.alarm.direction}ward {quantity} at {level.alarm.since_s:.1f}–"
                         f"{level.alarm.time_s:.1f} s (CUSUM alarm) that the level since then does not hold "
                         f"({level.ratio:.3g}× {what} [{level.ratio_ci[0]:.3g}, {level.ratio_ci[1]:.3g}]{short}): "
                         "not counted as degraded")
    return AxisComparison(noise, step, line, alpha, notes, beyond, allan)
