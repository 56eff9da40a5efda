"""Residual statistics of a fitted noise model: whiteness, spectral lines and Allan-variance misfit.

These are the error measures the closed loop reports before and after each step and the statistics the
detectors (:mod:`.detectors`) build on. They take arrays only; nothing here knows about the estimator.

* Standardised one-step innovations e_t = ν_t / √S_t of a correct linear-Gaussian model are i.i.d. N(0, 1)
  (the innovations of the Kalman filter, paper 000 appendix / paper 002 eq. 7). :func:`ljung_box` tests them for
  serial correlation, :func:`spectral_peaks` for narrow spectral lines.
* The Allan-variance misfit compares the empirical AV of the data with the model's theoretical AV
  (paper 000 section 2): :func:`av_misfit` is the RMS of log10(AV_data / AV_model) over τ and
  :func:`av_misfit_z` standardises the log ratio by the AV estimate's confidence interval.

Missing samples are NaN in the innovation arrays; they are dropped (autocorrelations and periodograms use the
remaining samples with NaN set to zero after centring, which is exact for the sums and a small approximation for
the effective sample size when only a few samples are missing).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage, stats
from scipy.fft import next_fast_len

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


def acf(e: np.ndarray, nlags: int) -> np.ndarray:
    """Sample autocorrelation ρ_1..ρ_nlags of a series (NaN = missing), computed with an FFT.

    ρ_k = Σ_t ẽ_t ẽ_{t+k} / Σ_t ẽ_t², ẽ the centred series (the estimator the Ljung–Box statistic uses).
    """
    x, _ = _finite_centred(e)
    nlags = int(nlags)
    if not 1 <= nlags < x.size:
        raise ValueError(f"nlags must be in [1, {x.size - 1}], got {nlags}")
    size = next_fast_len(2 * x.size - 1, real=True)  # zero padding: the linear, not circular, correlation
    spec = np.fft.rfft(x, size)
    r = np.fft.irfft(spec * np.conj(spec), size)[: nlags + 1]
    return r[1:] / r[0]


@dataclass(frozen=True)
class LjungBox:
    """Ljung–Box portmanteau test of whiteness (Ljung & Box 1978).

    Q = n(n+2) Σ_{k=1}^{h} ρ_k² / (n − k) ~ χ²_h under i.i.d. residuals.

    Attributes
    ----------
    q : float
        The statistic.
    lags : int
        h.
    p_value : float
        P(χ²_h ≥ q).
    worst_lag : int
        Lag with the largest |ρ_k| (for messages such as "residuals correlated at lag 3").
    worst_rho : float
        ρ at that lag.
    """

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
    """Largest narrow line of a periodogram relative to its local median floor.

    Attributes
    ----------
    frequency : float
        Frequency [Hz] of the peak, refined by parabolic interpolation of the log periodogram.
    bin : int
        Periodogram bin of the peak (frequency bin·fs/n_fft).
    ratio : float
        Peak power / local median power (the "residual spectral peak ratio").
    statistic : float
        s = ratio·ln 2, the peak in units of the floor's mean (a periodogram ordinate of white noise is
        σ²·Exp(1), whose median is σ² ln 2), corrected for the uncertainty of the median floor so that it is
        Exp(1)-distributed at each bin under white residuals.
    log10_p : float
        log10 of the Bonferroni-corrected p-value of the largest line: 1 − (1 − e^{−statistic})^M over the M
        searched bins (Fisher's g-test form for the maximum of M independent exponential ordinates).
    n_bins : int
        M.
    """

    frequency: float
    bin: int
    ratio: float
    statistic: float
    log10_p: float
    n_bins: int


def chi2_log10_sf(q: float, dof: int) -> float:
    """log10 P(χ²_dof ≥ q), finite far into the tail.

    Where scipy's ``logsf`` underflows to −inf, the leading term of the upper incomplete gamma function,
    Γ(k/2, q/2)/Γ(k/2) ≈ (q/2)^{k/2−1} e^{−q/2} / Γ(k/2) (q ≫ k), is used.
    """
    value = float(stats.chi2.logsf(q, dof))
    if math.isfinite(value):
        return value / math.log(10.0)
    half = 0.5 * dof
    return ((half - 1.0) * math.log(0.5 * q) - 0.5 * q - math.lgamma(half)) / math.log(10.0)


def max_exponential_log10_p(statistic: float, m: int) -> float:
    """log10 P(max of m i.i.d. Exp(1) ≥ statistic) = log10(1 − (1 − e^{−s})^m), stable for large s."""
    q = math.exp(-statistic) if statistic < 700 else 0.0
    if q == 0.0 or m * q < 1e-10:
        return (math.log(m) - statistic) / math.log(10.0)
    return math.log10(-math.expm1(m * math.log1p(-q)))


def periodogram(e: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """One-sided raw periodogram I_k = |Σ e_t e^{−2πikt/n}|²/n at f_k = k/(n·dt), k = 1..⌊(n−1)/2⌋."""
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
    """The (corrected, Exp(1) under white residuals) line statistic of :func:`spectral_peaks` at the bin nearest
    ``frequency`` [Hz]: whether a *given* line is still in the residuals."""
    freqs, power = periodogram(e, dt)
    k = int(np.argmin(np.abs(freqs - frequency)))
    lo, hi = max(0, k - half_width), min(freqs.size, k + half_width + 1)
    floor = float(np.median(power[lo:hi]))
    return floor_corrected(float(power[k] / floor * math.log(2.0)), half_width)


def _line_ratios(e: np.ndarray, dt: float, f_min: float | None,
                 half_width: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int]:
    """Frequencies, periodogram, its ratio to the running median floor (0 below ``f_min``), the number of bins
    searched and the floor's half-width used (:func:`spectral_peaks`)."""
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
    """The line at bin index ``k``: its frequency refined by a parabola through the log periodogram."""
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
    """The largest line of the periodogram of ``e`` against its running median floor.

    Parameters
    ----------
    e : (N,) array
        Standardised innovations (or any residual whose floor is locally flat); NaN = missing.
    dt : float
        Sampling period [s].
    f_min : float, optional
        Lowest frequency searched [Hz]; default 4 / record length (lines need a few periods to be lines).
    half_width : int
        Half-width of the running-median window in bins; a line narrower than this is a peak.

    Notes
    -----
    For standardised innovations the periodogram ordinate at f is the score statistic for adding a sinusoid
    at f to the model (the whitening filter scales the sinusoid and the noise alike), so this is the
    Lagrange-multiplier test of a missing sinusoid; the running median makes it robust to the broad
    misfit a missing GM leaves in the spectrum.
    """
    freqs, power, ratio, m, half_width = _line_ratios(e, dt, f_min, half_width)
    return _peak_at(int(np.argmax(ratio)), freqs, power, ratio, m=m, half_width=half_width)


#: Lines of :func:`spectral_lines` closer than this many bins to a stronger one are taken for its sidelobes.
LINE_SEPARATION_BINS = 3


def max_exponential_threshold(m: int, alpha: float) -> float:
    """The value the maximum of ``m`` i.i.d. Exp(1) exceeds with probability ``alpha``: −ln(1 − (1 − α)^{1/m})."""
    return float(-math.log(-math.expm1(math.log1p(-alpha) / m)))


def spectral_lines(e: np.ndarray, dt: float, *, alpha: float, f_min: float | None = None,
                   half_width: int = FLOOR_HALF_WIDTH) -> list[SpectralPeak]:
    """The largest line of the periodogram (:func:`spectral_peaks`'s, significant or not), then every other line
    whose statistic exceeds the level-``alpha`` bound of the largest of the M searched bins
    (:func:`max_exponential_threshold`), strongest first; a bin within :data:`LINE_SEPARATION_BINS` of a stronger
    line belongs to it. One periodogram and floor serve them all.

    Beyond the papers: each line after the first is significant on its own at family-wise level α (the largest of
    the bins that hold no line stays below the bound with probability 1 − α), so a dozen vibration lines are seen
    at once rather than one per step.
    """
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


def log_av_sd(av_ci: tuple[np.ndarray, np.ndarray], level: float = 0.95) -> np.ndarray:
    """Standard deviation of ln AV_hat implied by a (lo, hi) confidence interval at ``level``.

    For a χ²_ν-based AV interval, ln AV_hat has standard deviation ≈ √(2/ν), and the interval spans
    ≈ ±z·√(2/ν) in ln; inverting gives sd = (ln hi − ln lo) / (2z).
    """
    lo, hi = (np.asarray(a, dtype=float) for a in av_ci)
    if np.any(lo <= 0) or np.any(hi <= lo):
        raise ValueError("AV confidence intervals must satisfy 0 < lo < hi")
    z = stats.norm.ppf(0.5 + level / 2.0)
    return (np.log(hi) - np.log(lo)) / (2.0 * z)


def av_misfit_z(av_data: np.ndarray, av_ci: tuple[np.ndarray, np.ndarray], av_model: np.ndarray,
                level: float = 0.95) -> np.ndarray:
    """Per-τ standardised misfit z_τ = ln(AV_data / AV_model) / sd(ln AV_hat), ≈ N(0, 1) if the model holds."""
    return np.log(np.asarray(av_data, float) / np.asarray(av_model, float)) / log_av_sd(av_ci, level)


@dataclass(frozen=True)
class ResidualErrors:
    """The loop's error measures for one fitted model (see ``docs/loop.md``).

    Attributes
    ----------
    loglik, bic : float
        Log-likelihood and BIC of the fit (comparable between the loop's steps, see the pipeline).
    av_misfit : float
        RMS over τ of log10(AV_data / AV_model).
    ljung_box_p : float
        Ljung–Box p-value of the standardised innovations.
    ljung_box_q : float
        Its statistic, over ``ljung_box_lags`` lags.
    peak_ratio : float
        Largest periodogram line of the standardised innovations over its local median floor.
    peak_frequency : float
        Where [Hz].
    """

    loglik: float
    bic: float
    av_misfit: float
    ljung_box_p: float
    ljung_box_q: float
    ljung_box_lags: int
    peak_ratio: float
    peak_frequency: float


def residual_errors(e: np.ndarray, dt: float, *, loglik: float, bic: float, av_data: np.ndarray,
                    av_model: np.ndarray, lags: int = 20) -> ResidualErrors:
    """All error measures of one fit from its standardised innovations and its Allan variances."""
    lb = ljung_box(e, lags)
    peak = spectral_peaks(e, dt)
    return ResidualErrors(loglik=float(loglik), bic=float(bic), av_misfit=av_misfit(av_data, av_model),
                          ljung_box_p=lb.p_value, ljung_box_q=lb.q, ljung_box_lags=lb.lags,
                          peak_ratio=peak.ratio, peak_frequency=peak.frequency)
