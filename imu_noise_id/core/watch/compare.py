"""One axis of a recording against its reference (docs/analysis.md, "Compare against a reference"): noise level both
ways, bias step and new line in the reference model's innovations, each at α = min(0.01, λ·T) for T hours."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..diagnostics import detectors as det
from ..diagnostics.scan_tail import StepScanTail
from ..diagnostics.whitening import WhiteningFilter
from ..noise.base import Component
from ..noise.components import RW, WN, total_allan_variance
from .allan_watch import DEFAULT_TAUS, watch_allan
from .noise_level import (
    DEFAULT_FALSE_ALARMS_PER_HOUR,
    DEFAULT_RATIO,
    SPIKE_Z,
    NoiseLevel,
    beyond_limit,
    watch_noise_level,
)

#: Largest relative difference between a recording's rate and its reference's.
RATE_TOLERANCE = 0.02
#: Relative tolerance of a reference density given without a usable interval (±10 %).
DEFAULT_TOLERANCE = 0.10
#: Lines within this many frequency bins of a known line are the known line.
KNOWN_LINE_BINS = 3
#: Lowest frequency [Hz] searched for a new line (below it: the noise model's long-τ wander).
LINE_MIN_FREQUENCY = 0.1


@dataclass(frozen=True)
class AxisReference:
    """An axis's reference: N [u/√Hz] and its 95 % interval ((nan, nan): none), final model (None: WN), known lines
    [Hz], K's 95 % interval [u/s/√Hz] (None: none given)."""

    noise_density: float
    noise_density_ci: tuple[float, float]
    components: list[Component] | None = None
    known_lines: tuple[float, ...] = ()
    random_walk_ci: tuple[float, float] | None = None

    def model(self, dt: float) -> list[Component]:
        return list(self.components) if self.components else [WN(self.noise_density)]

    def step_model(self, dt: float) -> list[Component]:
        """The model the step and line tests whiten with: :meth:`model` with its random walk at the upper end of K's
        interval (one added there where the model has none and the end is above 0), the most slow wander the
        reference allows, so that a walk the calibration record underestimated is not taken for steps; why:
        docs/analysis.md, "Why the watch's step test reads the scan's own correlation"."""
        model = self.model(dt)
        high = self.random_walk_ci[1] if self.random_walk_ci is not None else math.nan
        if not (math.isfinite(high) and high > 0.0):
            return model
        if not any(isinstance(c, RW) for c in model):
            return [*model, RW(high)]
        return [RW(max(high, c.random_walk)) if isinstance(c, RW) else c for c in model]

    def density_interval(self) -> tuple[tuple[float, float], str]:
        """N's 95 % interval [u/√Hz] (±:data:`DEFAULT_TOLERANCE` without one) and a note saying which."""
        lo, hi = self.noise_density_ci
        if math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= self.noise_density <= hi:
            return (lo, hi), ""
        tol = DEFAULT_TOLERANCE
        return ((1 - tol) * self.noise_density, (1 + tol) * self.noise_density), (
            f"the reference's N has no interval: ±{100 * tol:g} % used")

    def pair_variance(self, tau: float, dt: float) -> float:
        """2·AV(τ) [u²] of the reference model at ``dt`` [s]: variance of consecutive τ-means' difference."""
        return 2.0 * float(total_allan_variance(self.model(dt), np.array([tau]), dt)[0])

    def difference_variance(self, dt: float) -> tuple[float, tuple[float, float], str]:
        """E[(y_{t+1} − y_t)²] = 2·AV(dt) [u²] of the reference, its interval (from N's) and note."""
        v = self.pair_variance(dt, dt)
        (lo, hi), note = self.density_interval()
        return v, (v * (lo / self.noise_density) ** 2, v * (hi / self.noise_density) ** 2), note

    def difference_variance_at(self, noise_density: float, dt: float) -> float:
        """E[(y_{t+1} − y_t)²] [u²] of the reference model scaled to density ``noise_density`` [u/√Hz]."""
        return self.difference_variance(dt)[0] * (noise_density / self.noise_density) ** 2


@dataclass(frozen=True)
class AxisComparison:
    """An axis's outcome: ``noise``, ``step``, ``line``, ``notes``, the spec ``limit`` test, ``allan`` (τ [s] → level
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
            out.append(f"bias step of {p['size']:.3g} at {p['time']:.1f} s")
        if self.line is not None:
            p = self.line.params
            out.append(f"new line at {p['frequency']:.4g} Hz (amplitude {p.get('amplitude', math.nan):.3g})")
        return out


def rate_mismatch(rate_hz: float, reference_rate_hz: float, source: str) -> str | None:
    """Why a recording at ``rate_hz`` cannot be compared with a reference at ``reference_rate_hz``, or None."""
    if abs(rate_hz - reference_rate_hz) <= RATE_TOLERANCE * reference_rate_hz:
        return None
    made = f"the reference {source}" if source else "the reference"
    return (f"{made} was made at {reference_rate_hz:.6g} Hz, this IMU runs at {rate_hz:.6g} Hz: compare against an "
            "analysis of a recording at the same rate")


def reference_innovations(y: np.ndarray, whitening: WhiteningFilter) -> np.ndarray:
    """The standardized innovations of ``y`` [u] under the reference's model (``whitening``), its level's GLS
    coefficient removed, clipped at ±:data:`~.noise_level.SPIKE_Z` and NaN over the filter's start-up."""
    first = y[np.isfinite(y)][0]
    e = whitening.whiten(np.nan_to_num(y - first, nan=0.0))
    # the level's GLS coefficient removed (why: docs/analysis.md, "Why the step and line tests remove the level first")
    constant = whitening.whiten(np.ones(e.size))
    e = e - constant * (float(constant @ e) / float(constant @ constant))
    # clipped as the noise level's pairs are (why: docs/analysis.md, "Why the noise-level test caps a pair …")
    e = np.clip(e, -SPIKE_Z, SPIKE_Z)
    e[: min(10, e.size // 100)] = np.nan  # the filter's start-up
    return e


def bias_step(e: np.ndarray, dt: float, whitening: WhiteningFilter, alpha: float, *,
              tails: dict[int, StepScanTail] | None = None) -> det.Finding | None:
    """The significant bias step (or None) in the innovations ``e`` (:func:`reference_innovations`) at ``dt`` [s] at
    level ``alpha``, the maximum over positions judged by the scan's own correlation
    (:class:`~..diagnostics.scan_tail.StepScanTail`; why: docs/analysis.md, "Why the watch's step test reads the scan's
    own correlation"), kept in ``tails`` by the number of samples when given (one filter per dictionary)."""
    tails = {} if tails is None else tails
    if e.size not in tails:
        tails[e.size] = StepScanTail.of(whitening, e.size, max(20, e.size // 200))
    tail = tails[e.size]
    step = det.detect_step(e, dt, whitening, alpha=alpha, min_segment=tail.min_segment, tail=tail)
    return step if step.significant else None


def new_line(e: np.ndarray, dt: float, whitening: WhiteningFilter, alpha: float,
             known: tuple[float, ...]) -> det.Finding | None:
    """The strongest significant line (or None) in the innovations ``e`` at ``dt`` [s] at level ``alpha`` from
    :data:`LINE_MIN_FREQUENCY` up; lines within :data:`KNOWN_LINE_BINS` of ``known`` [Hz] are not new."""
    near = KNOWN_LINE_BINS / (e.size * dt)
    for line in det.detect_sinusoids(e, dt, whitening, alpha=alpha, f_min=LINE_MIN_FREQUENCY):
        if line.significant and all(abs(line.params["frequency"] - f) > near for f in known):
            return line
    return None


def step_and_line(y: np.ndarray, dt: float, whitening: WhiteningFilter, alpha: float,
                  known: tuple[float, ...]) -> tuple[det.Finding | None, det.Finding | None]:
    """:func:`bias_step` and :func:`new_line` in ``y`` [u]'s :func:`reference_innovations`, each at ``alpha``."""
    e = reference_innovations(y, whitening)
    return bias_step(e, dt, whitening, alpha), new_line(e, dt, whitening, alpha, known)


def compare_axis(y: np.ndarray, dt: float, reference: AxisReference, *, ratio: float = DEFAULT_RATIO,
                 false_alarms_per_hour: float = DEFAULT_FALSE_ALARMS_PER_HOUR,
                 limit: float | None = None) -> AxisComparison:
    """The module's tests on ``y`` [u] at ``dt`` [s], also at ``allan_watch.DEFAULT_TAUS`` and against ``limit``
    [u/√Hz]; ValueError on fewer than 200 samples or a noiseless reference."""
    y = np.asarray(y, dtype=float)
    v, interval, note = reference.difference_variance(dt)
    noise = watch_noise_level(y, dt, v, interval, ratio=ratio, false_alarms_per_hour=false_alarms_per_hour)
    hours = y.size * dt / 3600.0
    alpha = min(det.ALPHA, false_alarms_per_hour * hours)
    whitening = WhiteningFilter.from_components(reference.step_model(dt), dt)
    step, line = step_and_line(y, dt, whitening, alpha, reference.known_lines)
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
