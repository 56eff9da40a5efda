"""Spectral lines offered to a GMWM selection: the record's significant lines (pooled-periodogram search,
:func:`~imu_noise_id.core.diagnostics.lines.detect_broad_line`, shaped by
:func:`~imu_noise_id.core.diagnostics.lines.line_shape`), each tried as a resonance (OSC) beside the selection's
winner and kept where the WIC under the larger structure's weight falls (Guerrier et al. 2015's criterion, the
weight of the structure nesting both as in :func:`.select.select_gmwm`).

Beyond the GMWM papers, whose candidates are the classical processes: a measured IMU's vibration line or mechanical
resonance is no such process, and on dyadic scales its power sits where the white noise is read (a 20 Hz line at
τ = 0.01–0.04 s, a 0.56 Hz one at 0.5–2 s). Without it the efficient weight fits the finest scales, where the WV is
most precise, and the white noise is read high. The scales barely see a line's frequency: an OSC the fit moves beyond
:data:`LINE_WINDOW` of its line is not that line, and the trial is refused (docs/gmwm.md, "Why: lines offered to the
selection")."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...diagnostics.detectors import ALPHA
from ...diagnostics.lines import POOLED_RESOLUTIONS, LineShape, detect_broad_line, line_shape
from ...errors import InputError
from ...noise.modelspec import model_name, parameter_labels
from ...noise.resonant import MAX_DAMPING, OSC
from ...quality import interpolate_missing
from ...wavelet.covariance import narrowest_line
from ...wavelet.variance import WaveletVariance
from . import engine as eng
from .fit import Estimate, GmwmOptions, estimate_structure

#: Lines searched for at most, strongest first.
MAX_LINES = 3


@dataclass(frozen=True)
class LineTrial:
    """One line offered: its shape, the structure with it, the WICs without and with it under the latter's weight,
    whether it was kept, and the estimate with it (None when it could not be fitted, ``error`` saying why)."""

    line: LineShape
    model: str
    wic_without: float
    wic_with: float
    kept: bool
    k: int = 0
    error: str = ""
    estimate: Estimate | None = field(default=None, repr=False)

    def row(self) -> dict:
        """The trial as a row of the selection table (``delta_wic``: with − without, under one weight)."""
        text = (f"OSC at {self.line.frequency:.4g} Hz, {self.line.bandwidth:.3g} Hz wide, from the record's spectrum: "
                + (self.error or ("kept" if self.kept else "refused") + f" (WIC {self.wic_without:.6g} -> "
                                                                           f"{self.wic_with:.6g})"))
        return {"model": self.model, "k": self.k, "delta_wic": self.wic_with - self.wic_without, "line": text}


def record_lines(y: np.ndarray, dt: float, slope: float, *, alpha: float = ALPHA,
                 max_lines: int = MAX_LINES) -> list[LineShape]:
    """Up to ``max_lines`` significant lines of the record ``y`` [u] at ``dt`` [s] (its least-squares line of slope
    ``slope`` [u/s] removed, gaps filled), strongest first: each found by the pooled-periodogram search at level
    ``alpha`` (Bonferroni over its pooled bins) outside twice the bandwidth of those found before."""
    x = interpolate_missing(np.asarray(y, dtype=float))
    t = (np.arange(x.size) - 0.5 * (x.size - 1)) * dt
    x = x - x.mean() - slope * t
    resolution = 1.0 / (x.size * dt)
    found: list[LineShape] = []
    exclude: list[float] = []
    for _ in range(max_lines):
        finding = detect_broad_line(x, dt, alpha=alpha, exclude=tuple(exclude))
        if not finding.significant:
            break
        shape = line_shape(x, dt, finding.params["frequency"], resolution=int(finding.params["resolution"]))
        if shape.sigma <= 0.0:
            break
        found.append(shape)
        span = 2.0 * shape.bandwidth + POOLED_RESOLUTIONS[0] * resolution
        step = POOLED_RESOLUTIONS[0] * resolution
        exclude += list(np.arange(shape.frequency - span, shape.frequency + span + step, step))
    return found


#: Relative distance |f̂/f − 1| within which a fitted OSC still describes its line: the WV's dyadic scales barely see
#: a line's frequency, and a fit that moved the OSC away (to hold broad power elsewhere) is not the line's.
LINE_WINDOW = 0.1

#: Starts of a line's OSC beside its measured shape: bandwidth × and σ × (its power partly held by the winner's
#: components already, its width on dyadic scales barely seen).
START_BANDWIDTH_FACTOR, START_SIGMA_FACTOR = 4.0, 0.5


def _resonances(line: LineShape, n: int, dt: float) -> list[OSC]:
    """The OSC starts of a line: its frequency, bandwidth (at least the GMWM's narrowest,
    :func:`~imu_noise_id.core.wavelet.covariance.narrowest_line`, at most an OSC's widest) and σ as measured, and
    with the bandwidth × :data:`START_BANDWIDTH_FACTOR`, the σ × :data:`START_SIGMA_FACTOR`."""
    widest = 2.0 * MAX_DAMPING * line.frequency * 0.99
    bandwidth = min(max(line.bandwidth, 1.01 * narrowest_line(line.frequency, n, dt)), widest)
    return [OSC(line.frequency, min(b, widest), s) for b in (bandwidth, START_BANDWIDTH_FACTOR * bandwidth)
            for s in (line.sigma, START_SIGMA_FACTOR * line.sigma)]


def _strays(est: Estimate, lines: list[LineShape]) -> list[str]:
    """The fitted OSCs of ``est`` that lie beyond :data:`LINE_WINDOW` of every line of ``lines`` not already taken by
    a nearer one, in words."""
    free = list(lines)
    strays = []
    for osc in sorted((c for c in est.components if isinstance(c, OSC)), key=lambda c: c.frequency):
        near = min(free, key=lambda ln: abs(osc.frequency / ln.frequency - 1.0), default=None)
        if near is None or abs(osc.frequency / near.frequency - 1.0) > LINE_WINDOW:
            strays.append(f"{osc.frequency:.4g} Hz")
        else:
            free.remove(near)
    return strays


def offer_lines(wv: WaveletVariance, winner: Estimate, lines: list[LineShape], *,
                options: GmwmOptions) -> tuple[Estimate, list[LineTrial]]:
    """``winner`` with each of ``lines`` (strongest first) added as an OSC where it lowers the WIC (module docstring),
    and every trial."""
    best, trials, taken = winner, [], []
    for line in lines:
        starts = [[*best.components, osc] for osc in _resonances(line, wv.n, wv.dt)]
        name = model_name(starts[0])
        try:
            est = estimate_structure(wv, starts[0], options=options, more_starts=tuple(starts[1:]))
        except (InputError, ValueError) as exc:
            trials.append(LineTrial(line, name, math.nan, math.nan, False, error=f"not fitted: {exc}"))
            continue
        strays = _strays(est, [*taken, line])
        if strays:
            trials.append(LineTrial(line, name, math.nan, math.nan, False, k=len(parameter_labels(est.components)),
                                    estimate=est, error=f"refused: the fit moved its OSC to {', '.join(strays)}, "
                                                        f"beyond {LINE_WINDOW:.0%} of the line"))
            continue
        weights = eng.Weights.at(est.problem.runs, est.components)  # the structure nesting both
        without, with_line = best.wic(weights), est.wic(weights)
        kept = with_line < without
        trials.append(LineTrial(line, name, without, with_line, kept, k=len(parameter_labels(est.components)),
                                estimate=est))
        if kept:
            best, taken = est, [*taken, line]
    return best, trials
