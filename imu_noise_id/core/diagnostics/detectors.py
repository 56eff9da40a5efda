"""Detectors tracing a residual signature to the effect a model lacks, as :class:`Finding` at level α (docs/loop.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize, stats

from .local_dft import LocalDft
from .residuals import (
    SpectralPeak,
    acf,
    chi2_log10_sf,
    ljung_box,
    max_exponential_threshold,
    spectral_lines,
    spectral_peaks,
)
from .scan_tail import ShiftedStep, StepScanTail
from .whitening import ScoreBasis, ScoreTest, WhiteningFilter, score_test

#: Default significance level of every detector.
ALPHA = 0.01
_LN10 = math.log(10.0)


@dataclass(frozen=True)
class Finding:
    """One detector's verdict on one candidate missing effect.

    Attributes
    ----------
    effect : ``GM``, ``RW``, ``RR``, ``QN``, ``SIN``, ``TEMP``, ``STEP``, ``OUTLIERS``, …; detector : the test's name
    statistic, threshold : the statistic and what it must exceed at ``level`` α; log10_p : multiplicity-corrected
    params : initial values, SI (``tau`` [s], ``sigma`` [u], ``frequency`` [Hz], ``coefficient`` [u/°C], …)
    evidence : one line of what was seen; indices : samples concerned (outliers); members : a family added at once
    """

    effect: str
    detector: str
    statistic: float
    threshold: float
    log10_p: float
    level: float
    params: dict[str, float]
    evidence: str
    indices: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    members: tuple[Finding, ...] = ()

    @property
    def significant(self) -> bool:
        return bool(self.statistic > self.threshold)

    @classmethod
    def proposed(cls, effect: str, detector: str, evidence: str, params: dict[str, float] | None = None) -> Finding:
        """A candidate the loop proposes itself (a re-selection move, a joint-search start): no statistic tested
        (statistic, threshold, log10_p and level 0), ``params`` its initial values."""
        return cls(effect=effect, detector=detector, statistic=0.0, threshold=0.0, log10_p=0.0, level=0.0,
                   params=dict(params or {}), evidence=evidence)


def bonferroni_log10_p(log10_p_single: float, m: int) -> float:
    """log₁₀ of the Bonferroni p-value of the most extreme of ``m`` tests (capped at p = 1)."""
    return min(0.0, log10_p_single + math.log10(max(m, 1)))


def norm_log10_sf(z: float) -> float:
    """log₁₀ P(Z > z) for a standard normal Z, finite far in the tail."""
    return float(stats.norm.logsf(z) / _LN10)


# --------------------------------------------------------------------------------------------- outliers
def detect_outliers(e: np.ndarray, *, alpha: float = ALPHA, only: np.ndarray | None = None) -> Finding:
    """Spikes: robust z_t = (e_t − median)/(1.4826·MAD) beyond Φ⁻¹(1 − α/(2n)), all in ``indices``; ``only``: samples
    tested."""
    e = np.asarray(e, dtype=float)
    ok = np.isfinite(e)
    n = int(ok.sum())
    if n < 16:
        raise ValueError("detect_outliers: need at least 16 finite innovations")
    med = float(np.median(e[ok]))
    scale = 1.4826 * float(np.median(np.abs(e[ok] - med)))
    if scale <= 0:
        raise ValueError("detect_outliers: innovations have zero spread")
    z = np.where(ok, (e - med) / scale, 0.0)
    if only is not None:
        keep = np.zeros(z.size, bool)
        keep[np.asarray(only, dtype=int)] = True
        z = np.where(keep, z, 0.0)
    z_star = float(stats.norm.isf(alpha / (2 * n)))
    idx = np.flatnonzero(np.abs(z) > z_star)
    zmax = float(np.max(np.abs(z)))
    log10_p = bonferroni_log10_p(norm_log10_sf(zmax) + math.log10(2.0), n)
    tail_ratio = float(np.std(e[ok]) / scale)
    return Finding(
        effect="OUTLIERS", detector="robust_z", statistic=zmax, threshold=z_star, log10_p=log10_p, level=alpha,
        params={"count": float(idx.size), "fraction": idx.size / n, "max_abs_z": zmax, "std_over_mad": tail_ratio},
        evidence=f"{idx.size} innovation(s) beyond |z| = {z_star:.2f} (robust MAD scale, Bonferroni over {n}); "
                 f"max |z| = {zmax:.1f}, std/MAD-σ = {tail_ratio:.2f}",
        indices=idx,
    )


# --------------------------------------------------------------------------------------------- sinusoid
def detect_sinusoid(e: np.ndarray, dt: float, whitening: WhiteningFilter, *, alpha: float = ALPHA,
                    f_min: float | None = None) -> Finding:
    """A narrow line: periodogram peak over its median floor above s* = −ln(1 − (1 − α)^{1/M}); f refined, amplitude
    by GLS."""
    return _sinusoid(e, dt, whitening, spectral_peaks(e, dt, f_min=f_min), alpha=alpha)


def detect_sinusoids(e: np.ndarray, dt: float, whitening: WhiteningFilter, *, alpha: float = ALPHA,
                     f_min: float | None = None) -> list[Finding]:
    """:func:`detect_sinusoid`'s finding, then every other line significant at family-wise level α, strongest first."""
    return [_sinusoid(e, dt, whitening, line, alpha=alpha) for line in spectral_lines(e, dt, alpha=alpha, f_min=f_min)]


def _sinusoid(e: np.ndarray, dt: float, whitening: WhiteningFilter, peak: SpectralPeak, *, alpha: float) -> Finding:
    """The finding of ``peak``; a line's frequency refined, amplitude and phase from the score test."""
    s_star = max_exponential_threshold(peak.n_bins, alpha)
    if peak.statistic <= s_star:  # no line: nothing to refine or size (each score test whitens two columns)
        return Finding(effect="SIN", detector="periodogram", statistic=peak.statistic, threshold=s_star,
                       log10_p=peak.log10_p, level=alpha,
                       params={"frequency": peak.frequency, "peak_ratio": peak.ratio},
                       evidence=f"no spectral line: the largest periodogram ordinate is {peak.ratio:.1f}× the local "
                                f"median floor at {peak.frequency:.5g} Hz (threshold {s_star / math.log(2):.1f}× "
                                f"over {peak.n_bins} bins)")
    t = np.arange(np.asarray(e).size) * dt
    basis = ScoreBasis.of(e, whitening.whitened_constant(t.size))

    def test_at(f: float) -> ScoreTest:
        cols = np.column_stack([np.sin(2 * math.pi * f * t), np.cos(2 * math.pi * f * t)])
        return basis.test(whitening.whiten(cols))

    # frequency refined within ±1 bin on |Σ e_k e^{−2πif t_k}|² (why: docs/diagnostics.md, "Why lines are refined …")
    resolution = 1.0 / (t.size * dt)
    upper = min(peak.frequency + resolution, 0.5 / dt - resolution)
    lower = min(max(peak.frequency - resolution, resolution), upper)  # a peak in the Nyquist bin: the last bin
    local = LocalDft.of(e, dt, 0.5 * (lower + upper))
    best = optimize.minimize_scalar(lambda f: -abs(local.at(f)) ** 2, method="bounded", bounds=(lower, upper),
                                    options={"xatol": 1e-3 * resolution})
    start = min(peak.frequency, upper)
    frequency, st = max(((f, test_at(f)) for f in (start, float(best.x))), key=lambda pair: pair[1].statistic)
    amplitude = float(np.hypot(*st.coef))
    return Finding(
        effect="SIN", detector="periodogram", statistic=peak.statistic, threshold=s_star, log10_p=peak.log10_p,
        level=alpha,
        params={"frequency": frequency, "amplitude": amplitude,
                "phase": float(math.atan2(st.coef[1], st.coef[0])), "peak_ratio": peak.ratio},
        evidence=f"spectral line at {frequency:.5g} Hz, {peak.ratio:.1f}× the local median floor "
                 f"(threshold {s_star / math.log(2):.1f}× over {peak.n_bins} bins), amplitude ≈ {amplitude:.3g}",
    )


# ------------------------------------------------------------------------------------------ temperature
def detect_temperature(e: np.ndarray, temperature: np.ndarray, whitening: WhiteningFilter, *,
                       alpha: float = ALPHA) -> Finding:
    """Score test of a thermal bias coefficient [u/°C]: e against the whitened ``temperature`` [°C]."""
    temp = np.asarray(temperature, dtype=float)
    if temp.shape != np.asarray(e).shape or not np.all(np.isfinite(temp)):
        raise ValueError("temperature must be finite and sampled at the IMU times (same length as the data)")
    if np.ptp(temp) <= 0:
        raise ValueError("temperature is constant: no thermal coefficient can be identified")
    x = temp - temp.mean()
    st = score_test(e, whitening.whiten(x), whitening.whitened_constant(x.size))
    z_star = float(stats.norm.isf(alpha / 2))
    t_abs = math.sqrt(st.statistic)
    coef = float(st.coef[0])
    return Finding(
        effect="TEMP", detector="temperature_score", statistic=t_abs, threshold=z_star, log10_p=st.log10_p,
        level=alpha, params={"coefficient": coef, "coefficient_se": float(st.se[0])},
        evidence=f"innovations correlate with temperature: score |T| = {t_abs:.1f} (threshold {z_star:.2f}), "
                 f"coefficient ≈ {coef:.3g} ± {float(st.se[0]):.2g} per °C",
    )


# ------------------------------------------------------------------------------------------------ ramp
def detect_ramp(e: np.ndarray, dt: float, whitening: WhiteningFilter, *, alpha: float = ALPHA) -> Finding:
    """A rate ramp (drift): score test of a whitened ramp regressor t, the constant a nuisance."""
    n = np.asarray(e).size
    t = np.arange(n) * dt
    st = score_test(e, whitening.whiten(t - t.mean()), whitening.whitened_constant(n))
    z_star = float(stats.norm.isf(alpha / 2))
    t_abs = math.sqrt(st.statistic)
    slope = float(st.coef[0])
    return Finding(
        effect="RR", detector="ramp_score", statistic=t_abs, threshold=z_star, log10_p=st.log10_p, level=alpha,
        params={"slope": slope},
        evidence=f"innovations correlate with a ramp: score |T| = {t_abs:.1f} (threshold {z_star:.2f}), "
                 f"slope ≈ {slope:.3g} u/s",
    )


# ------------------------------------------------------------------------------------------------ steps
def step_scan(e: np.ndarray, whitening: WhiteningFilter, min_segment: int) -> np.ndarray:
    """Score statistics T_k of a level shift at every k (NaN outside [min_segment, n − min_segment]), the whitened
    constant s projected out: T_k = (c_k − c_0 a_k/‖s‖²)/√(‖s_{0..n−k−1}‖² − a_k²/‖s‖²), c = e ⋆ s, a = s ⋆ s."""
    e = np.nan_to_num(np.asarray(e, dtype=float), nan=0.0)
    n = e.size
    shifted = ShiftedStep.of(whitening.whitened_constant(n))
    a, s2, tail = shifted.a, shifted.s2, shifted.tail
    c = np.fft.irfft(np.fft.rfft(e, shifted.size) * np.conj(shifted.fs), shifted.size)[:n]
    num = c - c[0] * a / s2
    den = tail - a**2 / s2
    out = np.full(n, np.nan)
    k = np.arange(min_segment, n - min_segment)
    good = den[k] > 1e-12 * s2
    out[k[good]] = num[k[good]] / np.sqrt(den[k[good]])
    return out


def detect_step(e: np.ndarray, dt: float, whitening: WhiteningFilter, *, alpha: float = ALPHA,
                min_segment: int | None = None, tail: StepScanTail | None = None) -> Finding:
    """A bias step: max_k |T_k| of :func:`step_scan`, its p-value Bonferroni over k or, with ``tail`` (the scan's
    :class:`~.scan_tail.StepScanTail` for these samples and filter), from the scan's own correlation (Siegmund's
    approximation); size the GLS coefficient at the best k."""
    e = np.asarray(e, dtype=float)
    n = e.size
    m = max(20, n // 200) if min_segment is None else int(min_segment)
    if n < 4 * m:
        raise ValueError(f"detect_step: {n} samples are too few for segments of {m}")
    if tail is not None and (tail.n, tail.min_segment) != (n, m):
        raise ValueError(f"detect_step: a tail of {tail.n} samples and segments of {tail.min_segment} for a scan of "
                         f"{n} and {m}")
    t_k = step_scan(e, whitening, m)
    k = int(np.nanargmax(np.abs(t_k)))
    t_max = float(abs(t_k[k]))
    n_scan = int(np.isfinite(t_k).sum())
    if tail is None:
        z_star = float(stats.norm.isf(alpha / (2 * n_scan)))
        log10_p = bonferroni_log10_p(norm_log10_sf(t_max) + math.log10(2.0), n_scan)
        multiplicity = f"Bonferroni over {n_scan} positions"
    else:
        z_star = tail.threshold(alpha)
        log10_p = math.log10(max(tail.sf(t_max), 1e-300))
        multiplicity = f"the maximum over {n_scan} correlated positions"
    step = (np.arange(n) >= k).astype(float)
    st = score_test(e, whitening.whiten(step), whitening.whitened_constant(n))
    size = float(st.coef[0])
    return Finding(
        effect="STEP", detector="step_scan", statistic=t_max, threshold=z_star, log10_p=log10_p, level=alpha,
        params={"index": float(k), "time": k * dt, "size": size, "size_se": float(st.se[0])},
        evidence=f"level shift of {size:.3g} at t = {k * dt:.6g} s (sample {k}): |T| = {t_max:.1f} "
                 f"(threshold {z_star:.2f}, {multiplicity})",
    )


# ------------------------------------------------------------------------------------ serial correlation
def detect_correlation(e: np.ndarray, dt: float, *, alpha: float = ALPHA, lags: int = 20) -> Finding:
    """Correlated innovations → GM: Ljung–Box over ``lags``; starts τ ≈ dt·Σ_k ρ_k/ρ_1 (ρ > 2/√n), σ share √ρ_1."""
    lb = ljung_box(e, lags)
    n = int(np.isfinite(e).sum())
    rho = acf(e, min(n // 4, 5000))
    noise = 2.0 / math.sqrt(n)
    r1 = max(float(rho[0]), noise)
    below = np.flatnonzero(rho < noise)
    stop = int(below[0]) if below.size else rho.size
    tau = dt * max(1.0, float(np.sum(rho[:stop])) / r1)
    thr = float(stats.chi2.isf(alpha, lags))
    return Finding(
        effect="GM", detector="ljung_box", statistic=lb.q, threshold=thr,
        log10_p=chi2_log10_sf(lb.q, lags), level=alpha,
        params={"tau": tau, "sigma_share": math.sqrt(r1)},
        evidence=f"innovations correlated: Ljung–Box Q = {lb.q:.1f} over {lags} lags (threshold {thr:.1f}), "
                 f"largest ρ = {lb.worst_rho:.3f} at lag {lb.worst_lag}; decay time ≈ {tau:.3g} s",
    )
