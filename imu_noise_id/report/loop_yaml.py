"""Serialise closed-loop results (:class:`imu_noise_id.pipelines.loop.LoopResult`) for ``model.yaml``: per axis a
``loop:`` list (one entry per step: ``model``, ``added``, ``dropped``, ``how``, ``evidence``, ``error``,
``components``, ``regressors``, ``outliers``, ``rejected``) and ``loop_verdict`` (schema: docs/loop.md, "Outputs")."""

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
