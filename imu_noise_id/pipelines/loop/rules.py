"""The loop's judgement of one fit against another: AV misfit, do no harm, BIC tie, AV band, practical significance."""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from ...core.constants import CONFIDENCE_95
from ...core.diagnostics.residuals import av_misfit_z
from ...core.estimation.readouts.walk_evidence import record_walk, walk_interval
from .state import Diagnosis

#: "Do no harm": the most a step may raise the RMS AV misfit z (model vs data, in sd of the AV estimates).
AV_Z_TOLERANCE = 1.0


def av_rms_z(diag: Diagnosis) -> float:
    """RMS over τ of the AV misfit z-scores (log AV of data vs model in units of the estimate's sd)."""
    z = av_misfit_z(diag.av_data, diag.av_ci, diag.av_model)
    z = z[np.isfinite(z)]
    return float(np.sqrt(np.mean(z**2))) if z.size else 0.0


#: BIC tie below this (Kass & Raftery 1995, JASA 90: ΔBIC > 6 "strong"); the AV then decides (``judge``, ``better``).
BIC_TIE = 6.0
#: How much a tie-breaking move must lower the RMS AV misfit z: twice what do-no-harm lets a step raise it.
AV_Z_GAIN = 2.0 * AV_Z_TOLERANCE


#: Practical significance: a model AV within this relative error of the data's AV is good enough at that τ.
PRACTICAL_AV_ERROR = 0.10


def simultaneous_z(diag: Diagnosis, level: float) -> tuple[np.ndarray, np.ndarray, float]:
    """(z_τ, finite mask, the simultaneous bound on |z|: Bonferroni over the octaves of τ)."""
    z = av_misfit_z(diag.av_data, diag.av_ci, diag.av_model)
    ok = np.isfinite(z)
    if not ok.any():
        return z, ok, 0.0
    octaves = max(1.0, math.log2(diag.tau[ok].max() / diag.tau[ok].min()) + 1.0)
    return z, ok, float(stats.norm.isf((1.0 - level) / (2.0 * octaves)))


def practically_negligible(diag: Diagnosis, level: float = CONFIDENCE_95) -> bool:
    """Whether at every τ the model's AV lies inside the data's simultaneous band
    (:func:`av_inside_band`) or within :data:`PRACTICAL_AV_ERROR` of the data's AV."""
    z, ok, bound = simultaneous_z(diag, level)
    rel = np.abs(diag.av_model / np.where(diag.av_data > 0, diag.av_data, np.nan) - 1.0)
    return bool(ok.any() and np.all((np.abs(z[ok]) <= bound) | (rel[ok] <= PRACTICAL_AV_ERROR)))


def av_inside_band(diag: Diagnosis, level: float = CONFIDENCE_95) -> bool:
    """Whether the model's AV lies inside the data's ``level`` band at every τ, Bonferroni over the J octaves
    spanned: |z_τ| ≤ Φ⁻¹(1 − (1 − level)/(2J))."""
    z, ok, bound = simultaneous_z(diag, level)
    return bool(ok.any() and np.max(np.abs(z[ok])) <= bound)


def max_relative_av_error(diag: Diagnosis) -> float:
    """Largest |AV_model / AV_data − 1| over τ."""
    ok = diag.av_data > 0
    return float(np.max(np.abs(diag.av_model[ok] / diag.av_data[ok] - 1.0))) if ok.any() else math.nan


def with_av_misfit(passed: bool, verdict: str, diag: Diagnosis) -> tuple[bool, str]:
    """The loop's (passed, verdict) with the AV misfit counted as a residual: a final AV outside the
    band (:func:`av_inside_band`) and not :func:`practically_negligible` fails, with the largest relative AV error."""
    if not passed or av_inside_band(diag) or practically_negligible(diag):
        return passed, verdict
    return False, (f"AV misfit left unexplained: no detector fires, but the final model's Allan variance leaves the "
                   f"data's 95 % band (largest relative AV error {100 * max_relative_av_error(diag):.0f} %)")


def walk_moved(before: Diagnosis, after: Diagnosis) -> tuple[float, float, float] | None:
    """(K after, interval before) when ``after``'s random walk over the record (:func:`.walk_evidence.record_walk`)
    lies outside ``before``'s 95 % interval (:func:`.walk_evidence.walk_interval`, from Whittle's Fisher information of
    the record's length); None when it lies inside or ``before``'s walk is not identified: none, an interval not
    determined, or one that reaches zero on the linear scale, K(1 ± 1.96 sd(ln K)) (ln(hi/lo) = 2·1.96·sd(ln K) ≥ 2)."""
    fit = before.fit
    ci = walk_interval(list(fit.components), fit.n, fit.dt)
    if ci is None or ci[0] <= 0.0 or math.log(ci[1] / ci[0]) >= 2.0:
        return None
    k = record_walk(list(after.fit.components), fit.n * fit.dt)
    return None if ci[0] <= k <= ci[1] else (k, ci[0], ci[1])


def judge(before: Diagnosis, after: Diagnosis, *, tie: bool = False, guard_walk: bool = False) -> tuple[bool, str]:
    """The BIC and do-no-harm rules: kept when the BIC is lower and the RMS AV misfit z rises by at most
    :data:`AV_Z_TOLERANCE`. With ``tie`` (a move adding no parameter), a BIC worse by less than :data:`BIC_TIE` is kept
    when the RMS AV misfit z falls by :data:`AV_Z_GAIN` or more. With ``guard_walk`` (re-selection's drops; beyond the
    papers), do no harm to K: a drop that takes the random walk outside ``before``'s 95 % interval
    (:func:`walk_moved`) is kept only on strong evidence, a BIC lower by :data:`BIC_TIE` or more or the AV misfit z
    lower by :data:`AV_Z_GAIN`. Additions are not guarded: the K they move away from is conditional on a structure
    that lacked what they add (docs/loop.md, "The loop's rules" 5). Returns (kept, reason)."""
    improved = after.errors.bic < before.errors.bic
    z0, z1 = av_rms_z(before), av_rms_z(after)
    no_harm = z1 <= z0 + AV_Z_TOLERANCE
    av_gain = z1 <= z0 - AV_Z_GAIN
    why = (f"BIC {before.errors.bic:.1f} → {after.errors.bic:.1f} ({'better' if improved else 'not better'}); "
           f"AV misfit z {z0:.1f} → {z1:.1f}{'' if no_harm else ' (worse)'}")
    if tie and not improved and after.errors.bic - before.errors.bic < BIC_TIE and av_gain:
        return True, why + f"; a BIC tie (within {BIC_TIE:g}) that the AV breaks"
    moved = walk_moved(before, after) if guard_walk and improved and no_harm else None
    if moved is not None and before.errors.bic - after.errors.bic < BIC_TIE and not av_gain:
        k, lo, hi = moved
        return False, why + (f"; K {k:.3g} leaves its interval [{lo:.3g}, {hi:.3g}] on less than strong evidence "
                             f"(BIC lower by less than {BIC_TIE:g}, AV misfit z not lower by {AV_Z_GAIN:g})")
    return improved and no_harm, why


def better(a: Diagnosis, b: Diagnosis) -> bool:
    """Of two kept moves, the better: the lower BIC unless the two tie (:data:`BIC_TIE`), then the lower AV misfit."""
    if abs(a.errors.bic - b.errors.bic) < BIC_TIE:
        return av_rms_z(a) < av_rms_z(b)
    return a.errors.bic < b.errors.bic
