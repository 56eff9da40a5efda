"""Residual statistics of a fitted noise model: whiteness, spectral lines and Allan-variance misfit. Standardised
innovations e_t = ν_t/√S_t of a correct model are i.i.d. N(0, 1) (paper 000 appendix, paper 002 eq. 7); AV misfit as
paper 000 sec. 2. NaN = missing (dropped, or 0 after centring)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage, stats
from scipy.fft import next_fast_len

from ..constants import CONFIDENCE_95
from ..deferred import Deferred

#: Half-width (in periodogram bins) of the window whose median is the local floor of :func:`spectral_peaks`.
FLOOR_HALF_WIDTH = 200


def _finite_centred(e: np.ndarray, name: str = "innovations") -> tuple[np.ndarray, int]:
    e = np.asarray(e, dtype=float).ravel()
    if e.size == 0:
        raise ValueError(f"{name} are empty")
    if np.any(np.isinf(e)):
        raise ValueError(f"{name} contain inf")
    ok = np.isfinite(e)
    n = int(ok.sum())
    if n < 16:
        raise ValueError(f"{name}: need at least 16 finite samples, got {n}")
    out = np.where(ok, e - e[ok].mean(), 0.0)
    return out, n


#: Up to this many lags the autocorrelation is summed lag by lag (nlags dot products), beyond it by FFT.
DIRECT_MAX_LAGS = 64


def acf(e: np.ndarray, nlags: int) -> np.ndarray:
    """Sample autocorrelation ρ_1..ρ_nlags: ρ_k = Σ_t ẽ_t ẽ_{t+k} / Σ_t ẽ_t², ẽ centred; lag by lag up to
    :data:`DIRECT_MAX_LAGS` lags, else by FFT."""
    x, _ = _finite_centred(e)
    nlags = int(nlags)
    if not 1 <= nlags < x.size:
        raise ValueError(f"nlags must be in [1, {x.size - 1}], got {nlags}")
    if nlags <= DIRECT_MAX_LAGS:
        return np.array([np.dot(x[:-k], x[k:]) for k in range(1, nlags + 1)]) / np.dot(x, x)
    size = next_fast_len(2 * x.size - 1, real=True)  # zero padding: the linear, not circular, correlation
    spec = np.fft.rfft(x, size)
    r = np.fft.irfft(spec * np.conj(spec), size)[: nlags + 1]
    return r[1:] / r[0]


@dataclass(frozen=True)
class LjungBox:
    """Ljung–Box (Ljung & Box 1978): ``q`` = n(n+2) Σ_{k≤h} ρ_k²/(n − k) ~ χ²_h, ``lags`` h, ``p_value``,
    ``worst_lag``, ``worst_rho``."""

    q: float
    lags: int
    p_value: float
    worst_lag: int
    worst_rho: float


def ljung_box(e: np.ndarray, lags: int = 20) -> LjungBox:
    """Ljung–Box test of the standardised innovations ``e`` over ``lags`` lags (NaN = missing)."""
    _, n = _finite_centred(e)
    rho = acf(e, lags)
    k = np.arange(1, lags + 1)
    q = float(n * (n + 2) * np.sum(rho**2 / (n - k)))
    worst = int(np.argmax(np.abs(rho)))
    return LjungBox(q=q, lags=int(lags), p_value=float(stats.chi2.sf(q, lags)), worst_lag=worst + 1,
                    worst_rho=float(rho[worst]))


@dataclass(frozen=True)
class SpectralPeak:
    """Largest narrow periodogram line over its local median: ``frequency`` [Hz], ``bin``, ``ratio``, ``statistic`` s
    = ratio·ln 2 (floor-corrected, Exp(1)), ``log10_p`` of 1 − (1 − e^{−s})^M, ``n_bins`` M."""

    frequency: float
    bin: int
    ratio: float
    statistic: float
    log10_p: float
    n_bins: int


def chi2_log10_sf(q: float, dof: int) -> float:
    """log10 P(χ²_dof ≥ q), finite far in the tail (asymptotic form where scipy underflows)."""
    value = float(stats.chi2.logsf(q, dof))
    if math.isfinite(value):
        return value / math.log(10.0)
    half = 0.5 * dof
    return ((half - 1.0) * math.log(0.5 * q) - 0.5 * q - math.lgamma(half)) / math.log(10.0)


def max_exponential_log10_p(statistic: float, m: int) -> float:
    """log10 P(max of m i.i.d. Exp(1) ≥ s) = log10(1 − (1 − e^{−s})^m)."""
    q = math.exp(-statistic) if statistic < 700 else 0.0
    if q == 0.0 or m * q < 1e-10:
        return (math.log(m) - statistic) / math.log(10.0)
    return math.log10(-math.expm1(m * math.log1p(-q)))


def periodogram(e: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """One-sided periodogram I_k = |Σ e_t e^{−2πikt/n}|²/n at f_k = k/(n·dt), k = 1..⌊(n−1)/2⌋."""
    x, _ = _finite_centred(e)
    n = x.size
    spec = np.abs(np.fft.rfft(x)) ** 2 / n
    k = np.arange(1, (n - 1) // 2 + 1)
    return k / (n * dt), spec[k]


def floor_corrected(raw: float, half_width: int) -> float:
    # The floor is a median of K = 2·half_width + 1 exponential ordinates, itself uncertain: its relative sd is
    # ≈ 1/(ln 2·√K), so P(I/floor·ln2 > s) ≈ e^{−s + s²v/2}, v = 1/(ln²2·K) (lognormal floor error). The
    # statistic is corrected to s − s²v/2 (linear beyond s = 1/v) so that it is again Exp(1) per bin.
    v = 1.0 / (math.log(2.0) ** 2 * (2 * half_width + 1))
    return raw - raw * raw * v / 2.0 if raw <= 1.0 / v else raw - 1.0 / (2.0 * v)


def line_statistic(e: np.ndarray, dt: float, frequency: float, half_width: int = FLOOR_HALF_WIDTH) -> float:
    """The corrected line statistic of :func:`spectral_peaks` at the bin nearest ``frequency`` [Hz]."""
    freqs, power = periodogram(e, dt)
    k = int(np.argmin(np.abs(freqs - frequency)))
    lo, hi = max(0, k - half_width), min(freqs.size, k + half_width + 1)
    floor = float(np.median(power[lo:hi]))
    return floor_corrected(float(power[k] / floor * math.log(2.0)), half_width)


def _line_ratios(e: np.ndarray, dt: float, f_min: float | None,
                 half_width: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int]:
    """Frequencies, periodogram, ratio to the running median (0 below ``f_min``), bins searched, half-width used."""
    freqs, power = periodogram(e, dt)
    if freqs.size < 4 * half_width:
        half_width = max(8, freqs.size // 8)
    floor = ndimage.median_filter(power, size=2 * half_width + 1, mode="reflect")
    n_total = freqs.size * 2 + 1
    f_lo = 4.0 / (n_total * dt) if f_min is None else float(f_min)
    search = freqs >= f_lo
    if not np.any(search):
        raise ValueError("spectral_peaks: no frequency above f_min; the record is too short")
    ratio = np.where(search, power / np.maximum(floor, np.finfo(float).tiny), 0.0)
    return freqs, power, ratio, int(search.sum()), half_width


def _peak_at(k: int, freqs: np.ndarray, power: np.ndarray, ratio: np.ndarray, *, m: int,
             half_width: int) -> SpectralPeak:
    stat = floor_corrected(float(ratio[k] * math.log(2.0)), half_width)
    freq = float(freqs[k])
    if 0 < k < freqs.size - 1 and power[k - 1] > 0 and power[k + 1] > 0:
        a, b, c = np.log(power[k - 1 : k + 2])
        denom = a - 2 * b + c
        if denom < 0:
            freq += float(0.5 * (a - c) / denom) * (freqs[1] - freqs[0])
    return SpectralPeak(frequency=freq, bin=k + 1, ratio=float(ratio[k]), statistic=stat,
                        log10_p=float(max_exponential_log10_p(stat, m)), n_bins=m)


def spectral_peaks(e: np.ndarray, dt: float, *, f_min: float | None = None,
                   half_width: int = FLOOR_HALF_WIDTH) -> SpectralPeak:
    """The largest periodogram line of ``e`` at ``dt`` [s] over its ±``half_width``-bin running median, from
    ``f_min`` [Hz] (default 4 / length)."""
    freqs, power, ratio, m, half_width = _line_ratios(e, dt, f_min, half_width)
    return _peak_at(int(np.argmax(ratio)), freqs, power, ratio, m=m, half_width=half_width)


#: Lines of :func:`spectral_lines` closer than this many bins to a stronger one are taken for its sidelobes.
LINE_SEPARATION_BINS = 3


def max_exponential_threshold(m: int, alpha: float) -> float:
    """−ln(1 − (1 − α)^{1/m}): exceeded by the maximum of ``m`` i.i.d. Exp(1) with probability ``alpha``."""
    return float(-math.log(-math.expm1(math.log1p(-alpha) / m)))


def spectral_lines(e: np.ndarray, dt: float, *, alpha: float, f_min: float | None = None,
                   half_width: int = FLOOR_HALF_WIDTH) -> list[SpectralPeak]:
    """The largest line, then every other above the level-``alpha`` bound of the max of M bins, strongest first; bins
    within :data:`LINE_SEPARATION_BINS` of a stronger line are its."""
    freqs, power, ratio, m, half_width = _line_ratios(e, dt, f_min, half_width)
    threshold = max_exponential_threshold(m, alpha)
    top = int(np.argmax(ratio))
    lines = [_peak_at(top, freqs, power, ratio, m=m, half_width=half_width)]
    if lines[0].statistic <= threshold:  # the statistic grows with the ratio: no weaker line is significant
        return lines
    taken = np.zeros(freqs.size, bool)
    taken[top] = True
    above = np.flatnonzero(ratio * math.log(2.0) > threshold)  # the correction only lowers a statistic
    for k in above[np.argsort(-ratio[above])]:
        if taken[max(0, k - LINE_SEPARATION_BINS): k + LINE_SEPARATION_BINS + 1].any():
            continue
        peak = _peak_at(int(k), freqs, power, ratio, m=m, half_width=half_width)
        if peak.statistic > threshold:
            lines.append(peak)
            taken[k] = True
    return lines


def av_misfit(av_data: np.ndarray, av_model: np.ndarray) -> float:
    """RMS over τ of log10(AV_data / AV_model) (0 = perfect; 0.3 ≈ a factor 2 on average)."""
    av_data = np.asarray(av_data, dtype=float)
    av_model = np.asarray(av_model, dtype=float)
    if av_data.shape != av_model.shape or av_data.size == 0:
        raise ValueError("av_data and av_model must be non-empty arrays of the same shape")
    ok = (av_data > 0) & (av_model > 0) & np.isfinite(av_data) & np.isfinite(av_model)
    if not np.any(ok):
        raise ValueError("no τ with positive finite AV in both data and model")
    return float(np.sqrt(np.mean(np.log10(av_data[ok] / av_model[ok]) ** 2)))


def log_av_sd(av_ci: tuple[np.ndarray, np.ndarray], level: float = CONFIDENCE_95) -> np.ndarray:
    """sd of ln AV_hat from its (lo, hi) interval at ``level``: (ln hi − ln lo)/(2z)."""
    lo, hi = (np.asarray(a, dtype=float) for a in av_ci)
    if np.any(lo <= 0) or np.any(hi <= lo):
        raise ValueError("AV confidence intervals must satisfy 0 < lo < hi")
    z = stats.norm.ppf(0.5 + level / 2.0)
    return (np.log(hi) - np.log(lo)) / (2.0 * z)


def av_misfit_z(av_data: np.ndarray, av_ci: tuple[np.ndarray, np.ndarray], av_model: np.ndarray,
                level: float = CONFIDENCE_95) -> np.ndarray:
    """z_τ = ln(AV_data/AV_model)/sd(ln AV_hat), ≈ N(0, 1) if the model holds."""
    return np.log(np.asarray(av_data, float) / np.asarray(av_model, float)) / log_av_sd(av_ci, level)


@dataclass(frozen=True)
class ResidualErrors:
    """A fit's error measures (docs/loop.md): ``loglik``, ``bic``, ``av_misfit``, ``ljung_box_p``/``_q``/``_lags``;
    ``spectral_peak`` (:func:`spectral_peaks` of the innovations, computed on first use: the loop judges a candidate
    by its BIC and AV, the report alone shows the peak) read as :attr:`peak_ratio` and :attr:`peak_frequency` [Hz]."""

    loglik: float
    bic: float
    av_misfit: float
    ljung_box_p: float
    ljung_box_q: float
    ljung_box_lags: int
    spectral_peak: Deferred[SpectralPeak]

    @property
    def peak_ratio(self) -> float:
        """The largest periodogram line over its local median floor."""
        return self.spectral_peak().ratio

    @property
    def peak_frequency(self) -> float:
        """Where that line is [Hz]."""
        return self.spectral_peak().frequency


def residual_errors(e: np.ndarray, dt: float, *, loglik: float, bic: float, av_data: np.ndarray,
                    av_model: np.ndarray, lags: int = 20) -> ResidualErrors:
    """All error measures of one fit from its standardised innovations ``e`` (read, not copied: not to be changed
    afterwards) and its Allan variances."""
    lb = ljung_box(e, lags)
    return ResidualErrors(loglik=float(loglik), bic=float(bic), av_misfit=av_misfit(av_data, av_model),
                          ljung_box_p=lb.p_value, ljung_box_q=lb.q, ljung_box_lags=lb.lags,
                          spectral_peak=Deferred(functools.partial(spectral_peaks, e, dt)))
