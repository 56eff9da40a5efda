"""AV signatures of a model's misfit, each traced to the missing component (GM, BI, RW, RR, QN) as a Finding."""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
from scipy import optimize, stats

from ..noise.components import GM, Component, total_allan_variance
from ..noise.flicker import PLATEAU
from ..noise.units import random_walk_at_allan_variance
from .detectors import ALPHA, Finding, bonferroni_log10_p, norm_log10_sf
from .residuals import av_misfit_z


def white_allan_variance(components: Iterable[Component], tau: np.ndarray, dt: float) -> np.ndarray | None:
    """AV [u²] at ``tau`` [s] of the white parts (WN, QN) of ``components`` at ``dt`` [s]: the level a long-τ deficit's
    excess is read above (:func:`detect_av_signatures`); None without one."""
    white = [c for c in components if c.name in ("WN", "QN")]
    return total_allan_variance(white, tau, dt) if white else None


def fit_gm_to_excess(tau: np.ndarray, excess: np.ndarray) -> tuple[float, float]:
    """GM (τ_c [s], σ [u]) whose AV best fits a positive AV excess in log space."""
    best = (math.inf, float(tau[0]), 0.0)
    log_ex = np.log(excess)
    for tc in np.geomspace(tau[0] / 2, tau[-1] * 3, 80):
        # the continuous-time shape: sampled ever more finely than the process's memory
        shape = GM(tau=float(tc), sigma=1.0).allan_variance(tau, 1e-3 * float(min(tc, tau[0])))
        log_s2 = float(np.mean(log_ex - np.log(shape)))
        cost = float(np.sum((log_ex - np.log(shape) - log_s2) ** 2))
        if cost < best[0]:
            best = (cost, float(tc), math.exp(0.5 * log_s2))
    return best[1], best[2]


def gm_beside_walk(tau: np.ndarray, excess: np.ndarray, sd: np.ndarray) -> tuple[float, float, float]:
    """GM (τ_c, σ) and random walk K whose AVs together best fit a positive AV excess (log space, weighted by
    ``sd``)."""
    best = (math.inf, float(tau[0]), 0.0, 0.0)
    walk = tau / 3.0  # the random walk's AV per unit K²
    weight = 1.0 / (sd * excess)
    for tc in np.geomspace(tau[0] / 2, tau[-1] * 3, 80):
        shape = GM(tau=float(tc), sigma=1.0).allan_variance(tau, 1e-3 * float(min(tc, tau[0])))
        basis = np.column_stack([shape, walk])
        coef, _ = optimize.nnls(basis * weight[:, None], excess * weight)
        model = basis @ coef
        if not np.all(model > 0):
            continue
        cost = float(np.sum((np.log(model / excess) / sd) ** 2))
        if cost < best[0]:
            best = (cost, float(tc), math.sqrt(coef[0]), math.sqrt(coef[1]))
    return best[1], best[2], best[3]


#: A long-τ deficit's GM and walk are fitted from this fraction of the τ where the deficit begins to the longest τ.
DEFICIT_REACH = 0.1


#: A flat AV excess: over at least FLAT_DECADES of τ, a smooth (quadratic in log-log) fit of it varies by at most a
#: factor FLAT_RATIO.
FLAT_DECADES, FLAT_RATIO = 1.0, 1.3


def flicker_level(tau: np.ndarray, excess: np.ndarray) -> float | None:
    """B [u] of an AV excess with a plateau (2 ln 2/π)·B² (IEEE Std 952) over :data:`FLAT_DECADES`; None if none."""
    best: tuple[float, float] | None = None
    for i in range(tau.size):
        window = (tau >= tau[i]) & (tau <= tau[i] * 10.0**FLAT_DECADES * 1.0001)
        if tau[window][-1] < tau[i] * 10.0**FLAT_DECADES * 0.9999 or window.sum() < 4 or np.any(excess[window] <= 0):
            continue
        x, y = np.log(tau[window]), np.log(excess[window])
        smooth = np.polyval(np.polyfit(x, y, 2), x)
        spread = float(smooth.max() - smooth.min())
        if spread <= math.log(FLAT_RATIO) and (best is None or spread < best[0]):
            best = (spread, math.sqrt(float(np.median(excess[window])) / PLATEAU))
    return None if best is None else best[1]


def _with_flicker(finding: Finding, tau: np.ndarray, excess: np.ndarray) -> list[Finding]:
    """``finding`` (a GM) and, when the excess is flat over a decade, a BI finding ranked just before it."""
    level = flicker_level(tau, excess)
    if level is None:
        return [finding]
    flicker = Finding(effect="BI", detector=finding.detector, statistic=finding.statistic,
                      threshold=finding.threshold, log10_p=finding.log10_p - 1e-9, level=finding.level,
                      params={**{k: v for k, v in finding.params.items() if k not in ("tau", "sigma")},
                              "bias_instability": level},
                      evidence=f"{finding.evidence.split(' → ')[0]}; flat over {tau[0]:.3g}–{tau[-1]:.3g} s → "
                               f"flicker noise (BI) with B ≈ {level:.3g}")
    return [flicker, finding]


def signature_threshold(m: int, alpha: float = ALPHA) -> float:
    """Φ⁻¹(1 − α/m): the |z| beyond which one of ``m`` τ counts, family-wise level α (Bonferroni over the m τ)."""
    return float(stats.norm.isf(alpha / m))


#: A band of AV excess is read as RW or RR only if it ends beyond this fraction of the longest τ.
LAST_DECADE = 0.1


def long_tau_deficit(z: np.ndarray, z_star: float) -> np.ndarray:
    """Indices of the τ where the model's AV lies significantly above the data's (z < −``z_star``) within the last
    stretch of τ where it lies above at all (z < 0): a long-τ deficit is read from there alone, not from a deficit at
    shorter τ (e.g. a filter shape's) that the data's AV crosses back over before it.

    Parameters
    ----------
    z : the AV misfit z_τ = ln(AV_data/AV_model)/sd(ln AV_hat) at ascending τ (:func:`.residuals.av_misfit_z`)
    z_star : the |z| a τ must exceed to count (:func:`signature_threshold`)

    Returns
    -------
    The indices, ascending; empty where no τ is significant.
    """
    significant = np.flatnonzero(z < -z_star)
    if significant.size == 0:
        return significant
    crossed = np.flatnonzero(z[: significant[-1]] >= 0)
    return significant[significant > crossed[-1]] if crossed.size else significant


def detect_av_signatures(tau: np.ndarray, av_data: np.ndarray, av_ci: tuple[np.ndarray, np.ndarray],
                         av_model: np.ndarray, *, av_white: np.ndarray | None = None,
                         alpha: float = ALPHA, threshold: float | None = None) -> list[Finding]:
    """Bands of τ where the data's AV is significantly above (or at long τ below) the model's, each traced to a
    component: z_τ = ln(AV_data/AV_model)/sd(ln AV_hat) beyond ``threshold`` (default :func:`signature_threshold` of
    the M τ); by position and slope of the excess QN (shortest τ, < −1.5), RR (> 1.5) or RW (to the last decade), else
    GM (and BI when flat); a long-τ deficit (:func:`long_tau_deficit`) → GM and K above ``av_white``. Rules:
    docs/loop.md."""
    tau = np.asarray(tau, dtype=float)
    av_data = np.asarray(av_data, dtype=float)
    av_model = np.asarray(av_model, dtype=float)
    m = tau.size
    if m < 3 or av_data.shape != tau.shape or av_model.shape != tau.shape:
        raise ValueError("detect_av_signatures: need ≥ 3 τ with matching AV arrays")
    z = av_misfit_z(av_data, av_ci, av_model)
    z_star = signature_threshold(m, alpha) if threshold is None else float(threshold)
    findings: list[Finding] = []
    deficit = long_tau_deficit(z, z_star)
    if deficit.size and tau[deficit[-1]] >= LAST_DECADE * tau[-1] and np.all(z[deficit[-1]:] < 0):
        white = av_data[0] * tau[0] / tau if av_white is None else np.asarray(av_white, dtype=float)
        hump = av_data - white
        use = (hump > 0) & (tau >= DEFICIT_REACH * tau[deficit[0]])
        if use.sum() >= 3:
            # the log excess's spread, up to a constant: the AV estimate's interval, scaled by the excess's share
            sd = np.log(av_ci[1] / av_ci[0]) * av_data / np.where(use, hump, 1.0)
            tc, sg, k = gm_beside_walk(tau[use], hump[use], sd[use])
            zmin = float(-z[deficit].min())
            params = {"tau": tc, "sigma": sg, "random_walk": k, "deficit": 1.0, "band_lo": float(tau[deficit[0]]),
                      "band_hi": float(tau[-1])}
            findings += _with_flicker(Finding(
                effect="GM", detector="av_band", statistic=zmin, threshold=z_star, level=alpha,
                log10_p=bonferroni_log10_p(norm_log10_sf(zmin), m), params=params,
                evidence=(f"model AV above the data at long τ (τ ≥ {tau[deficit[0]]:.3g} s, max |z| = {zmin:.1f}, "
                          f"threshold {z_star:.2f}): the data's AV is bounded → GM with τ_c ≈ {tc:.3g} s, "
                          f"σ ≈ {sg:.3g}")), tau[use], hump[use])
    idx = np.flatnonzero(z > z_star)
    if idx.size == 0:
        return findings
    runs = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
    for run in runs:
        t, ex = tau[run], av_data[run] - av_model[run]
        zmax = float(z[run].max())
        slope = float(np.polyfit(np.log(t), np.log(ex), 1)[0]) if run.size >= 2 else math.nan
        band = f"τ = {t[0]:.3g}–{t[-1]:.3g} s" if run.size > 1 else f"τ = {t[0]:.3g} s"
        # A bump: the excess peaks inside the band and has halved by its end.
        peaked = run.size >= 3 and int(np.argmax(ex)) < run.size - 1 and ex[-1] < 0.5 * ex.max()
        band_params = {"band_lo": float(t[0]), "band_hi": float(t[-1])}
        common = {"detector": "av_band", "statistic": zmax, "threshold": z_star, "level": alpha,
                  "log10_p": bonferroni_log10_p(norm_log10_sf(zmax), m)}
        if run[0] == 0 and (run.size == 1 or slope < -1.5) and run[-1] < m - 1:
            q = math.sqrt(float(np.median(ex * t**2 / 3.0)))
            findings.append(Finding(effect="QN", params={"Q": q, **band_params}, evidence=(
                f"AV above the model at short τ ({band}, max z = {zmax:.1f}, threshold {z_star:.2f}), "
                f"excess slope {slope:.2f} (QN: −2)"), **common))
        elif not peaked and (run[-1] == m - 1 or (slope > 0.5 and t[-1] >= LAST_DECADE * tau[-1])):
            if run.size >= 2 and slope > 1.5:
                findings.append(Finding(effect="RR", params={"slope": math.sqrt(float(np.median(2 * ex / t**2))),
                                                                **band_params},
                                        evidence=(f"AV above the model at long τ ({band}, max z = {zmax:.1f}), "
                                                  f"excess slope {slope:.2f} (RR: +2)"), **common))
            else:
                # the median AV per second of τ: the random walk's AV at τ = 1 s
                k = random_walk_at_allan_variance(float(np.median(ex / t)), 1.0)
                findings.append(Finding(effect="RW", params={"random_walk": k, **band_params},
                                        evidence=(f"AV above the model at long τ ({band}, max z = {zmax:.1f}), "
                                                  f"excess slope {slope:.2f} (RW: +1)"), **common))
        else:
            tc, sg = fit_gm_to_excess(t, ex) if run.size >= 2 else (float(t[0]) / 1.89, math.sqrt(ex[0] / 0.87))
            findings += _with_flicker(Finding(effect="GM", params={"tau": tc, "sigma": sg, **band_params}, evidence=(
                f"AV bump above the model ({band}, max z = {zmax:.1f}, threshold {z_star:.2f}) → GM with "
                f"τ_c ≈ {tc:.3g} s, σ ≈ {sg:.3g}"), **common), t, ex)
    return findings
