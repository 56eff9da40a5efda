"""Shape of a residual line (SIN or OSC) and the broad-line, harmonic and hump searches (docs/loop.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage, optimize, stats

from .detectors import Finding
from .residuals import FLOOR_HALF_WIDTH, floor_corrected, periodogram

#: Share of a line's excess power within ±2 bins of its peak above which it is a sinusoid (a pure sine: ≥ 0.9).
SIN_CONCENTRATION = 0.6
#: Window searched around the line: ±this fraction of its frequency (at least :data:`MIN_HALF_BINS` bins).
WINDOW_FRACTION = 0.1
MIN_HALF_BINS = 16
#: A ring of bins around the line's window belongs to the line when its excess exceeds this many noise sd.
RING_Z = 3.0


@dataclass(frozen=True)
class LineShape:
    """A line's excess over the periodogram floor: ``frequency`` (weighted median) [Hz], ``bandwidth`` (IQR, ≥ 2
    bins) [Hz], ``sigma`` [u] (σ² = 2/n Σ excess), ``concentration`` (share within ±2 bins), ``resolution`` 1/(n·dt)
    [Hz]."""

    frequency: float
    bandwidth: float
    sigma: float
    concentration: float
    resolution: float

    @property
    def kind(self) -> str:
        """``"SIN"`` at concentration ≥ :data:`SIN_CONCENTRATION`, else ``"OSC"``."""
        return "SIN" if self.concentration >= SIN_CONCENTRATION else "OSC"

    @property
    def reason(self) -> str:
        """Why it is that kind, in words."""
        share = f"{100 * self.concentration:.0f} % of its excess power within ±2 periodogram bins"
        if self.kind == "SIN":
            return f"a sinusoid: {share} (≥ {100 * SIN_CONCENTRATION:.0f} %)"
        return (f"a narrow-band oscillation: only {share} (< {100 * SIN_CONCENTRATION:.0f} %), spread over "
                f"{self.bandwidth:.3g} Hz ({self.bandwidth / self.resolution:.0f} bins)")


def line_shape(residual: np.ndarray, dt: float, frequency: float, *, resolution: int = 1) -> LineShape:
    """The line near ``frequency`` [Hz] in ``residual`` (finite, at ``dt`` [s]): floor the median periodogram beyond
    ±:data:`WINDOW_FRACTION` of the frequency, / ln 2; window from ±:data:`MIN_HALF_BINS` bins, doubled while its
    ring holds excess above :data:`RING_Z` sd. ``resolution`` > 1 (bins per pooled bin): window from one pooled bin
    to at least half of ±:data:`POOLED_FLOOR_HALF_WIDTH` pooled bins, within ±50 % of the frequency."""
    freqs, power = periodogram(residual, dt)
    n = int(np.asarray(residual).size)
    df = 1.0 / (n * dt)
    k0 = int(np.argmin(np.abs(freqs - frequency)))
    pooled_half = min((resolution * POOLED_FLOOR_HALF_WIDTH) // 2, k0 // 2) if resolution > 1 else 0
    widest = max(MIN_HALF_BINS, math.ceil(WINDOW_FRACTION * frequency / df), pooled_half)
    lo_w, hi_w = max(0, k0 - widest), min(freqs.size, k0 + widest + 1)
    side = np.concatenate([power[max(0, lo_w - widest): lo_w], power[hi_w: hi_w + widest]])
    floor = float(np.median(side if side.size >= 8 else power)) / math.log(2.0)
    excess = power - floor
    half = max(MIN_HALF_BINS, min(resolution // 2, widest // 2))
    while half < widest:
        ring = np.r_[excess[max(0, k0 - 2 * half): max(0, k0 - half)], excess[k0 + half + 1: k0 + 2 * half + 1]]
        if ring.size == 0 or ring.sum() <= RING_Z * floor * math.sqrt(ring.size):
            break
        half *= 2
    lo, hi = max(0, k0 - half), min(freqs.size, k0 + half + 1)
    line = np.clip(excess[lo:hi], 0.0, None)
    total = float(excess[lo:hi].sum())
    if total <= 0.0 or line.sum() <= 0.0:
        return LineShape(float(frequency), 2 * df, 0.0, 1.0, df)
    peak = lo + int(np.argmax(power[lo:hi]))
    near = float(excess[max(0, peak - 2): peak + 3].sum())
    cdf = np.cumsum(line) / float(line.sum())
    f = freqs[lo:hi]
    q25, q50, q75 = (float(np.interp(q, cdf, f)) for q in (0.25, 0.5, 0.75))
    return LineShape(frequency=q50, bandwidth=max(q75 - q25, 2 * df), sigma=math.sqrt(2.0 * total / n),
                     concentration=min(1.0, near / total), resolution=df)


#: Pooled resolutions (periodogram bins per pooled bin) of the broad-line search.
POOLED_RESOLUTIONS = (16, 256)
#: Half-width of the running-median floor, in pooled bins.
POOLED_FLOOR_HALF_WIDTH = 40


_NODES, _WEIGHTS = np.polynomial.hermite_e.hermegauss(24)
_WEIGHTS = _WEIGHTS / _WEIGHTS.sum()


def _log_sf(x: float, r: int, v: float) -> float:
    """ln P(X·e^{vZ} > x), X ~ Gamma(r, 1), Z ~ N(0, 1)."""
    terms = stats.gamma.logsf(x * np.exp(v * _NODES), r) + np.log(_WEIGHTS)
    return float(np.logaddexp.reduce(terms))


def _floor_error(r: int) -> float:
    """Relative sd ≈ √(π/2)/√(rK) of the running median of K = 2·HW + 1 ordinates of relative sd 1/√r."""
    return math.sqrt(math.pi / 2.0 / (r * (2 * POOLED_FLOOR_HALF_WIDTH + 1)))


def _pool(power: np.ndarray, freqs: np.ndarray, r: int) -> tuple[np.ndarray, np.ndarray]:
    m = freqs.size // r
    return freqs[: m * r].reshape(m, r).mean(axis=1), power[: m * r].reshape(m, r).mean(axis=1)


def _gamma_scaled(pooled: np.ndarray, floor: np.ndarray | float, r: int) -> np.ndarray:
    scale = stats.gamma.median(r) / r
    return r * pooled / np.maximum(np.asarray(floor) / scale, np.finfo(float).tiny)


def _gamma_test(x: float, r: int, v: float, alpha: float, tests: int) -> tuple[float, float]:
    """(log10 p, level-α threshold) of the max of ``tests`` Gamma(r, 1) statistics with floor error ``v``."""
    log10_p = min(0.0, _log_sf(x, r, v) / math.log(10.0) + math.log10(tests))
    target = math.log(alpha / tests)
    threshold = float(optimize.brentq(lambda c: _log_sf(c, r, v) - target, r, 100.0 * r + 1000.0))
    return log10_p, threshold


def _pooled(power: np.ndarray, freqs: np.ndarray, r: int) -> tuple[np.ndarray, np.ndarray]:
    centre, pooled = _pool(power, freqs, r)
    floor = ndimage.median_filter(pooled, size=2 * POOLED_FLOOR_HALF_WIDTH + 1, mode="reflect")
    return centre, _gamma_scaled(pooled, floor, r)


#: A pooled bin is a line's only when the pooled spectrum's excess over its floor falls below this fraction of the
#: bin's own excess somewhere between half its frequency and it (:func:`humps`).
HUMP_DIP = 0.5


def humps(x: np.ndarray, r: int) -> np.ndarray:
    """Which pooled statistics ``x`` stand on a hump: an excess below :data:`HUMP_DIP` × (x[k] − r) somewhere in
    [k/2, k)."""
    m = x.size
    out = np.zeros(m, dtype=bool)
    if m < 2:
        return out
    # sparse table of minima over [i, i + 2^j): min over [a, b) = min(T_j[a], T_j[b − 2^j]), j = ⌊log2(b − a)⌋
    table = [x]
    while 2 ** len(table) <= m:
        prev, step = table[-1], 2 ** (len(table) - 1)
        table.append(np.minimum(prev[:-step], prev[step:]))
    k = np.arange(1, m)
    lo = k // 2
    j = np.floor(np.log2(k - lo)).astype(int)
    low_min = np.empty(k.size)
    for jj in np.unique(j):
        at = j == jj
        low_min[at] = np.minimum(table[jj][lo[at]], table[jj][k[at] - 2**jj])
    out[1:] = low_min - r < HUMP_DIP * (x[1:] - r)
    return out


def pooled_line_statistic(e: np.ndarray, dt: float, frequency: float, resolution: int) -> float:
    """The statistic of :func:`detect_broad_line` at the pooled bin nearest ``frequency`` [Hz]."""
    freqs, power = periodogram(e, dt)
    centre, x = _pooled(power, freqs, int(resolution))
    return float(x[int(np.argmin(np.abs(centre - frequency)))])


def detect_broad_line(e: np.ndarray, dt: float, *, alpha: float, exclude: tuple[float, ...] = ()) -> Finding:
    """A line too wide for one bin: the periodogram pooled over r bins vs its running median, Gamma(r, 1) with the
    floor's lognormal error; Bonferroni, humps only."""
    freqs, power = periodogram(e, dt)
    best: tuple[float, float, float, float, int] | None = None  # (log10 p, statistic, threshold, f, r)
    usable = [r for r in POOLED_RESOLUTIONS if freqs.size // r >= 4 * POOLED_FLOOR_HALF_WIDTH]
    tests = sum(freqs.size // r for r in usable)
    for r in usable:
        centre, x = _pooled(power, freqs, r)
        x[~humps(x, r)] = 0.0
        width = r * (freqs[1] - freqs[0])
        for f_x in exclude:
            x[np.abs(centre - f_x) <= 1.5 * width] = 0.0
        k = int(np.argmax(x))
        log10_p, threshold = _gamma_test(float(x[k]), r, _floor_error(r), alpha, tests)
        if best is None or log10_p < best[0]:
            best = (log10_p, float(x[k]), threshold, float(centre[k]), r)
    if best is None:
        return Finding(effect="SIN", detector="pooled_periodogram", statistic=0.0, threshold=math.inf, log10_p=0.0,
                       level=alpha, params={}, evidence="record too short for the broad-line search")
    log10_p, x, threshold, f, r = best
    return Finding(effect="SIN", detector="pooled_periodogram", statistic=x, threshold=threshold, log10_p=log10_p,
                   level=alpha, params={"frequency": f, "resolution": r},
                   evidence=f"broad spectral line near {f:.4g} Hz: {r} bins pooled hold {x / r:.1f}× the local "
                            f"floor (threshold {threshold / r:.1f}× over {tests} pooled bins)")


#: Harmonics of a line searched for its family (2f₀ … HARMONIC_MAX·f₀).
HARMONIC_MAX = 6


def harmonics(e: np.ndarray, dt: float, frequency: float, bandwidth: float, *, alpha: float) -> list[float]:
    """Significant harmonics k·f₀ [Hz] (k = 2 … :data:`HARMONIC_MAX`): the largest line within ±max(2 bins, 2k·B)
    above s*."""
    freqs, power = periodogram(e, dt)
    df = freqs[1] - freqs[0]
    half_width = min(FLOOR_HALF_WIDTH, max(8, freqs.size // 8))
    floor = ndimage.median_filter(power, size=2 * half_width + 1, mode="reflect")
    ratio = power / np.maximum(floor, np.finfo(float).tiny) * math.log(2.0)
    windows = []
    for k in range(2, HARMONIC_MAX + 1):
        centre = k * frequency
        if centre >= 0.98 * freqs[-1]:
            break
        half = max(2.0 * df, 2.0 * k * bandwidth)
        windows.append(np.flatnonzero(np.abs(freqs - centre) <= half))
    m = sum(w.size for w in windows)
    if m == 0:
        return []
    threshold = -math.log(-math.expm1(math.log1p(-alpha) / m))
    found = []
    for w in windows:
        if w.size == 0:
            continue
        best = w[int(np.argmax(ratio[w]))]
        if floor_corrected(float(ratio[best]), half_width) > threshold:
            found.append(float(freqs[best]))
    return found


#: Bands the innovation spectrum is averaged over from 0 Hz to Nyquist by :func:`detect_innovation_hump`.
HUMP_BANDS = 64
#: Bands the ratio is smoothed over to locate a hump's peak and extent.
HUMP_SMOOTH = 5


@dataclass(frozen=True)
class InnovationHump:
    """A broad hump of the innovations' spectrum: ``finding`` (OSC), centre ``frequency`` and half-excess
    ``bandwidth`` [Hz], its bands' ``band_frequency`` [Hz] and ``ratio``."""

    finding: Finding
    frequency: float
    bandwidth: float
    band_frequency: np.ndarray
    ratio: np.ndarray


def detect_innovation_hump(e: np.ndarray, dt: float, *, alpha: float, bands: int = HUMP_BANDS) -> InnovationHump:
    """A resonance wider than the broad-line floor: band means of the periodogram against their median (Gamma(r)/r),
    Bonferroni, humps only."""
    freqs, power = periodogram(e, dt)
    r = freqs.size // bands
    if r < 16 or bands < 8:
        finding = Finding(effect="OSC", detector="innovation_hump", statistic=0.0, threshold=math.inf, log10_p=0.0,
                          level=alpha, params={}, evidence="record too short for the innovation-hump search")
        return InnovationHump(finding, math.nan, math.nan, np.zeros(0), np.zeros(0))
    centre, mean = _pool(power, freqs, r)
    x = _gamma_scaled(mean, float(np.median(mean)), r)
    candidates = np.where(humps(x, r), x, 0.0)
    statistic = float(np.max(candidates))
    log10_p, threshold = _gamma_test(statistic, r, math.sqrt(math.pi / 2.0 / (r * bands)), alpha, bands)
    # The hump's extent on the ratio smoothed over HUMP_SMOOTH bands (one band's ratio has sd 1/√r: its peak wanders).
    ratio = ndimage.uniform_filter1d(x / r, size=HUMP_SMOOTH, mode="nearest")
    k = int(np.argmax(np.where(candidates > 0, ratio, -np.inf)))
    half = 1.0 + 0.5 * (ratio[k] - 1.0)
    lo, hi = k, k
    while lo > 1 and ratio[lo - 1] >= half:
        lo -= 1
    while hi < bands - 1 and ratio[hi + 1] >= half:
        hi += 1
    excess = np.maximum(ratio[lo: hi + 1] - 1.0, 0.0)
    width = float(centre[1] - centre[0])
    frequency = float(np.sum(excess * centre[lo: hi + 1]) / excess.sum()) if excess.sum() > 0 else float(centre[k])
    bandwidth = (hi - lo + 1) * width
    finding = Finding(effect="OSC", detector="innovation_hump", statistic=statistic, threshold=threshold,
                      log10_p=log10_p, level=alpha, params={"frequency": frequency, "bandwidth": bandwidth},
                      evidence=f"innovations' spectrum {statistic / r:.2f}× its level in a band of {width:.3g} Hz "
                               f"(threshold {threshold / r:.2f}× over {bands} bands): a hump of {bandwidth:.3g} Hz "
                               f"centred at {frequency:.3g} Hz")
    return InnovationHump(finding, frequency, bandwidth, centre[lo: hi + 1], ratio[lo: hi + 1])
