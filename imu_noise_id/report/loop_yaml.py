"""Serialise closed-loop results (:class:`imu_noise_id.pipelines.closed_loop.LoopResult`) for ``model.yaml``.

Per axis the loop adds (schema: /work/shared/notes/architecture.md)::

    loop:                                   # first step = starting model
      - model: WN+RW
        added: null                         # effect added at this step (null for the first)
        how: null                           # state-space component | deterministic regressor | data cleaning
        evidence: null                      # what the detector saw
        error: {loglik: …, bic: …, av_misfit: …, ljung_box_p: …, peak_ratio: …, peak_frequency: …}
        components: [{type: WN, noise_density: …}, …]      # fitted, continuous-time SI units
        regressors: {SIN1: {frequency: …, amplitude: …, phase: …}, TEMP2: {coefficient: …}, STEP3: {…}}
        outliers: 0                         # samples flagged so far
        rejected: [{added: GM, model: WN+GM+RW, reason: "BIC … → … (not better); …"}]   # tried, not kept
    loop_verdict: {final_model: WN+RW+SIN, passed: true, verdict: "residuals pass: …",
                   remaining: ["…evidence still significant…"]}
"""

from __future__ import annotations

import math
from pathlib import Path

import yaml

from ..pipelines.closed_loop import CLEANING_EFFECTS, EXOG_EFFECTS, LoopResult, LoopStep

HOW = {**dict.fromkeys(EXOG_EFFECTS, "deterministic regressor"), **dict.fromkeys(CLEANING_EFFECTS, "data cleaning")}


def _num(x: float) -> float:
    x = float(x)
    return x if not math.isfinite(x) else float(f"{x:.6g}")


def step_to_dict(step: LoopStep) -> dict:
    """One ``loop:`` entry."""
    e = step.errors
    return {
        "model": step.model,
        "added": step.added,
        "how": None if step.added is None else HOW.get(step.added, "state-space component"),
        "evidence": step.evidence,
        "error": {"loglik": _num(e.loglik), "bic": _num(e.bic), "av_misfit": _num(e.av_misfit),
                  "ljung_box_p": _num(e.ljung_box_p), "peak_ratio": _num(e.peak_ratio),
                  "peak_frequency": _num(e.peak_frequency)},
        "components": [{"type": c.name, **{k: _num(v) for k, v in c.params().items()}}
                       for c in step.diagnosis.fit.components],
        "regressors": {k: {p: _num(v) for p, v in vals.items()} for k, vals in step.diagnosis.exog_values.items()},
        "outliers": int(step.state.flagged.size),
        "rejected": [{"added": t.finding.effect, "model": t.model, "reason": t.reason}
                     for t in step.trials if not t.accepted],
    }


def loop_to_dict(result: LoopResult) -> dict:
    """``{'loop': [...], 'loop_verdict': {...}}`` for one axis."""
    return {
        "loop": [step_to_dict(s) for s in result.steps],
        "loop_verdict": {"final_model": result.final.model, "passed": bool(result.passed), "verdict": result.verdict,
                         "remaining": [f.evidence for f in result.remaining]},
    }


def add_loop_to_model_yaml(path: str | Path, results: dict[str, LoopResult]) -> Path:
    """Add (or replace) each axis's ``loop:`` and ``loop_verdict:`` in ``model.yaml``; create it if absent.

    Axes without an entry yet get one with the final step's model, ``n``, ``dt`` and the loop.
    """
    path = Path(path)
    doc = yaml.safe_load(path.read_text()) if path.exists() else None
    doc = doc if isinstance(doc, dict) else {}
    axes = doc.setdefault("axes", {})
    for axis, result in results.items():
        entry = axes.setdefault(axis, {})
        entry.setdefault("model", result.final.model)
        entry.setdefault("n", int(result.n))
        entry.setdefault("dt", _num(result.dt))
        entry.update(loop_to_dict(result))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True, width=120))
    return path
