"""A bias step and a new spectral line in a recording's innovations under its reference's model (docs/analysis.md,
"Compare against a reference"): the tests ``compare`` runs on the whole record and the node on its windows."""

from __future__ import annotations

import numpy as np

from ..diagnostics import detectors as det
from ..diagnostics.scan_tail import StepScanTail
from ..diagnostics.whitening import WhiteningFilter
from .noise_level import SPIKE_Z

#: Fewest seconds of data on each side of a bias step: a knock (a burst of well under a second) at the edge of a
#: window or record cannot fill a segment and read as a step (docs/analysis.md, "Why a step needs seconds on each
#: side"); a step is found no sooner than this after it.
MIN_STEP_SEGMENT_S = 5.0
#: Lines within this many frequency bins of a known line are the known line.
KNOWN_LINE_BINS = 3
#: Lowest frequency [Hz] searched for a new line (below it: the noise model's long-τ wander).
LINE_MIN_FREQUENCY = 0.1
#: Fewest cycles a new line completes in the samples tested: below it a peak among the lowest bins is the model's
#: long-τ wander (a walk stronger than the reference's fills them all), not a line (docs/analysis.md, "Why a new
#: line must be resolved in its window").
LINE_MIN_CYCLES = 20


def reference_innovations(y: np.ndarray, whitening: WhiteningFilter) -> np.ndarray:
    """The standardized innovations of ``y`` [u] under the reference's model (``whitening``), its level's GLS
    coefficient removed, clipped at ±:data:`~.noise_level.SPIKE_Z` and NaN over the filter's start-up."""
    first = y[np.isfinite(y)][0]
    e = whitening.whiten(np.nan_to_num(y - first, nan=0.0))
    # the level's GLS coefficient removed (why: docs/analysis.md, "Why the step and line tests remove the level first")
    constant = whitening.whitened_constant(e.size)
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
        tails[e.size] = StepScanTail.of(whitening, e.size, max(20, e.size // 200, round(MIN_STEP_SEGMENT_S / dt)))
    tail = tails[e.size]
    step = det.detect_step(e, dt, whitening, alpha=alpha, min_segment=tail.min_segment, tail=tail)
    return step if step.significant else None


def new_line(e: np.ndarray, dt: float, whitening: WhiteningFilter, alpha: float, known: tuple[float, ...], *,
             bands: tuple[tuple[float, float], ...] = ()) -> det.Finding | None:
    """The strongest significant line (or None) in the innovations ``e`` at ``dt`` [s] at level ``alpha`` from
    :data:`LINE_MIN_FREQUENCY` or :data:`LINE_MIN_CYCLES` over the samples' span up, whichever is higher; lines
    within :data:`KNOWN_LINE_BINS` of ``known`` [Hz] or inside one of ``bands`` ((low, high) [Hz], the reference's
    resonances) are not new."""
    span = e.size * dt
    near = KNOWN_LINE_BINS / span
    lowest = max(LINE_MIN_FREQUENCY, LINE_MIN_CYCLES / span)
    for line in det.detect_sinusoids(e, dt, whitening, alpha=alpha, f_min=lowest):
        f = line.params["frequency"]
        if (line.significant and all(abs(f - k) > near for k in known)
                and not any(low <= f <= high for low, high in bands)):
            return line
    return None


def step_and_line(y: np.ndarray, dt: float, whitening: WhiteningFilter, alpha: float, known: tuple[float, ...], *,
                  bands: tuple[tuple[float, float], ...] = ()) -> tuple[det.Finding | None, det.Finding | None]:
    """:func:`bias_step` and :func:`new_line` (``known`` lines and resonance ``bands`` not new) in ``y`` [u]'s
    :func:`reference_innovations`, each at ``alpha``."""
    e = reference_innovations(y, whitening)
    return bias_step(e, dt, whitening, alpha), new_line(e, dt, whitening, alpha, known, bands=bands)
