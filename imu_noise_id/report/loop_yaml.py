"""Serialise closed-loop results (:class:`imu_noise_id.pipelines.loop.LoopResult`) for ``model.yaml``.

Per axis the loop adds (schema: /work/shared/notes/architecture.md)::

    loop:                                   # first step = starting model
      - model: WN+RW
        added: null                         # effect added at this step (null for the first)
        dropped: []                         # components dropped by the re-selection after the addition
        how: null                           # state-space component | deterministic regressor | data cleaning
        evidence: null                      # what the detector saw
        error: {loglik: …, bic: …, av_misfit: …, ljung_box_p: …, peak_ratio: …, peak_frequency: …}
        components: [{type: WN, noise_density: …}, …]      # fitted, continuous-time SI units
        regressors: {SIN1: {frequency: …, amplitude: …, phase: …}, TEMP2: {coefficient: …}, STEP3: {…}}
        outliers: 0                         # samples flagged so far
        rejected: [{added: GM, model: WN+GM+RW, reason: "BIC … → … (not better); …"}]   # tried, not kept
                                            # (re-selection trials read "added: RW, reason: drop RW: …")
    loop_verdict: {final_model: WN+OSC+SIN, passed: true, verdict: "residuals pass: …",
                   remaining: ["…evidence still significant…"],
                   av_inside_band: true,            # model AV inside the data's 95 % band at every τ
                   av_outside_band_tau: [],         # τ ranges [s] where it lies outside ([[lo, hi], …])
                   av_band: "The final model's …",  # the sentence report.html and the console print
                   max_rel_av_error: 0.08,          # largest |AV_model/AV_data − 1| over τ
                   note: ""}                        # e.g. evidence left but of no practical significance
"""

from __future__ import annotations

from ..pipelines.av_band import av_band_claim
from ..pipelines.loop import CLEANING_EFFECTS, EXOG_EFFECTS, LoopResult, LoopStep
from .numbers import num

HOW = {**dict.fromkeys(EXOG_EFFECTS, "deterministic regressor"), **dict.fromkeys(CLEANING_EFFECTS, "data cleaning")}


def step_to_dict(step: LoopStep) -> dict:
    """One ``loop:`` entry."""
    e = step.errors
    return {
        "model": step.model,
        "added": step.added,
        "dropped": list(step.dropped),
        "how": None if step.added is None else HOW.get(step.added, "state-space component"),
        "evidence": step.evidence,
        "error": {"loglik": float(e.loglik), "bic": float(e.bic), "av_misfit": num(e.av_misfit),
                  "ljung_box_p": num(e.ljung_box_p), "peak_ratio": num(e.peak_ratio),
                  "peak_frequency": num(e.peak_frequency)},
        "components": [{"type": c.name, **{k: num(v) for k, v in c.params().items()}}
                       for c in step.diagnosis.fit.components],
        "regressors": {k: {p: num(v) for p, v in vals.items()} for k, vals in step.diagnosis.exog_values.items()},
        "outliers": int(step.state.flagged.size),
        "rejected": [{"added": t.finding.effect, "model": t.model, "reason": t.reason}
                     for t in step.trials if not t.accepted],
    }


def loop_to_dict(result: LoopResult) -> dict:
    """``{'loop': [...], 'loop_verdict': {...}}`` for one axis."""
    return {
        "loop": [step_to_dict(s) for s in result.steps],
        "loop_verdict": {"final_model": result.final.model, "passed": bool(result.passed), "verdict": result.verdict,
                         "remaining": [f.evidence for f in result.remaining],
                         "av_inside_band": bool(result.av_inside_band), **av_band_claim(result).as_dict(),
                         "max_rel_av_error": num(result.max_rel_av_error), "note": result.note},
    }
