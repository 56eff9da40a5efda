"""The step and line tests of :mod:`.innovation_tests` on the last ``window_s`` s of stationary samples, one axis every
``every_s`` s, at α = λ · ``every_s`` / 3600 (union bound; the line test at α/2 on the window and α/2 on its last
half, which a line that began within it fills twice as densely); motion restarts the window. The node runs them
sample by sample (:class:`WindowedChecks`); ``compare`` runs the same windows over a recording
(:func:`scan_windows`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..diagnostics import detectors as det
from ..diagnostics.scan_tail import StepScanTail
from ..diagnostics.whitening import WhiteningFilter
from .axis_reference import AxisReference
from .innovation_tests import bias_step, new_line, reference_innovations

#: Seconds of contiguous stationary samples each test looks at.
DEFAULT_WINDOW_S = 120.0
#: Seconds of stationary data between two tests of one axis.
DEFAULT_EVERY_S = 10.0
#: Fewest seconds of contiguous stationary samples a test runs on.
MIN_WINDOW_S = 30.0


@dataclass(frozen=True)
class WindowFinding:
    """A first finding: ``kind`` step/line, ``value`` ([u] or [Hz]), ``amplitude`` [u], ``since_s``, ``time_s`` [s]."""

    kind: str
    value: float
    amplitude: float
    since_s: float
    time_s: float


def window_tests(stamps: np.ndarray, samples: np.ndarray, period: float, whitening: WhiteningFilter, *,
                 alpha: float, known: tuple[float, ...], bands: tuple[tuple[float, float], ...], kinds: set[str],
                 tails: dict[int, StepScanTail] | None = None) -> dict[str, det.Finding]:
    """One window's tests (module docstring) on ``samples`` [u] at ``stamps`` [s] and ``period`` [s] under
    ``whitening`` (the reference's ``step_model``), those of ``kinds`` ("step", "line") only, at level ``alpha``,
    ``known`` lines and resonance ``bands`` [Hz] not new (:func:`~.innovation_tests.new_line`):
    per kind its significant finding, its ``time`` param (step) the stamp of the step, a line's ``since`` param
    [s] the stamp from which the samples it was found in begin; ``tails``: :func:`~.innovation_tests.bias_step`'s
    cache."""
    e = reference_innovations(samples, whitening)
    out = {}
    if "step" in kinds:
        step = bias_step(e, period, whitening, alpha, tails=tails)
        if step is not None:
            out["step"] = replace(step, params={**step.params, "time": float(stamps[int(step.params["index"])])})
    if "line" in kinds:
        line, since = new_line(e, period, whitening, alpha / 2.0, known, bands=bands), float(stamps[0])
        half = samples.size // 2
        if line is None and half >= round(MIN_WINDOW_S / period):
            line = new_line(reference_innovations(samples[-half:], whitening), period, whitening, alpha / 2.0, known,
                            bands=bands)
            since = float(stamps[-half])
        if line is not None:
            out["line"] = replace(line, params={**line.params, "since": since})
    return out


def scan_windows(y: np.ndarray, dt: float, reference: AxisReference, *, false_alarms_per_hour: float,
                 window_s: float = DEFAULT_WINDOW_S, every_s: float = DEFAULT_EVERY_S) -> dict[str, det.Finding]:
    """The node's windowed tests over a static recording ``y`` [u] at ``dt`` [s]: the window of the last
    ``window_s`` s (fewer at the start, at least :data:`MIN_WINDOW_S`) ending every ``every_s`` s and at the last
    sample, each at α = ``false_alarms_per_hour`` · ``every_s`` / 3600. The windows number at most T / ``every_s``
    for T seconds of data, so by the union bound the scan raises at most ``false_alarms_per_hour`` false alarms per
    hour. Per kind ("step", "line") the first window's finding, stamped from the first sample (0 s); its
    ``window_end`` param [s] the end of the window that found it."""
    y = np.asarray(y, dtype=float)
    capacity, minimum, every = round(window_s / dt), round(MIN_WINDOW_S / dt), max(1, round(every_s / dt))
    ends = list(range(minimum, y.size + 1, every))
    if ends and ends[-1] != y.size:
        ends.append(y.size)
    whitening = WhiteningFilter.from_components(reference.step_model(dt), dt)
    bands = reference.resonance_bands(dt)
    alpha = false_alarms_per_hour * every_s / 3600.0
    stamps = np.arange(y.size) * dt
    tails: dict[int, StepScanTail] = {}
    found: dict[str, det.Finding] = {}
    for end in ends:
        kinds = {"step", "line"} - found.keys()
        if not kinds:
            break
        start = max(0, end - capacity)
        new = window_tests(stamps[start:end], y[start:end], dt, whitening, alpha=alpha, known=reference.known_lines,
                           bands=bands, kinds=kinds, tails=tails if end - start == capacity else None)
        for kind, finding in new.items():
            found[kind] = replace(finding, params={**finding.params, "window_end": float(stamps[end - 1])})
    return found


class WindowedChecks:
    """:mod:`.innovation_tests`' step and line tests on the last ``window_s`` [s] of stationary samples at ``period``
    [s], λ per axis and test (module docstring), sample by sample (:func:`window_tests` each time)."""

    def __init__(self, references: list[AxisReference], period: float, *, false_alarms_per_hour: float,
                 window_s: float = DEFAULT_WINDOW_S, every_s: float = DEFAULT_EVERY_S) -> None:
        if not (false_alarms_per_hour > 0 and window_s >= MIN_WINDOW_S and every_s > 0):
            raise ValueError(f"windowed checks need λ > 0, a window of ≥ {MIN_WINDOW_S:g} s and a positive period "
                             f"between tests, got {false_alarms_per_hour!r}, {window_s!r}, {every_s!r}")
        self.period = period
        self.references = references
        self.whitening = [WhiteningFilter.from_components(r.step_model(period), period) for r in references]
        self.bands = [r.resonance_bands(period) for r in references]
        # per axis, the step scan's tail on a full window (a filling one's is computed afresh, not kept)
        self.tails: list[dict[int, StepScanTail]] = [{} for _ in references]
        self.alpha = false_alarms_per_hour * every_s / 3600.0
        k = len(references)
        self.capacity = round(window_s / period)
        self.samples = np.zeros((self.capacity, k))
        self.stamps = np.zeros(self.capacity)
        self.count = 0  # contiguous stationary samples held (≤ capacity)
        self.next_slot = 0
        self.tick = max(1, round(every_s / period / k))
        self.since_tick = 0
        self.next_axis = 0
        self.minimum = round(MIN_WINDOW_S / period)
        self.findings: list[dict[str, WindowFinding]] = [{} for _ in range(k)]
        self.tests = 0

    def add(self, t: float, sample: np.ndarray) -> None:
        """A stationary sample at stamp ``t`` [s] (axes in the references' order)."""
        self.samples[self.next_slot] = sample
        self.stamps[self.next_slot] = t
        self.next_slot = (self.next_slot + 1) % self.capacity
        self.count = min(self.count + 1, self.capacity)
        self.since_tick += 1
        if self.since_tick >= self.tick and self.count >= self.minimum:
            self.since_tick = 0
            self._test(self.next_axis)
            self.next_axis = (self.next_axis + 1) % len(self.references)

    def break_chain(self) -> None:
        """Motion or a gap: the window starts again."""
        self.count = 0
        self.since_tick = 0

    def _window(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        order = (np.arange(self.next_slot - self.count, self.next_slot)) % self.capacity
        return self.stamps[order], self.samples[order, i]

    def _test(self, i: int) -> None:
        stamps, samples = self._window(i)
        self.tests += 1
        held = self.findings[i]
        if "step" in held and "line" in held:
            return
        now = float(stamps[-1])
        new = window_tests(stamps, samples, self.period, self.whitening[i], alpha=self.alpha,
                           known=self.references[i].known_lines, bands=self.bands[i],
                           kinds={"step", "line"} - held.keys(),
                           tails=self.tails[i] if self.count == self.capacity else None)
        if "step" in new:
            size = float(new["step"].params["size"])
            held["step"] = WindowFinding("step", size, size, new["step"].params["time"], now)
        if "line" in new:
            p = new["line"].params
            held["line"] = WindowFinding("line", float(p["frequency"]), float(p.get("amplitude", math.nan)),
                                         p["since"], now)
