"""``criteria.json``: paper 002's performance criteria over time (keys: docs/hypotheses.md)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from ..core.hypotheses.criteria import CriteriaResult


def criteria_document(result: CriteriaResult) -> dict[str, Any]:
    """The ``criteria.json`` mapping (shared vocabulary) of a :class:`CriteriaResult`."""
    return {
        "case": int(result.case) if str(result.case).isdigit() else result.case,
        "trials": result.trials,
        "dt": result.dt,
        "t": result.t.tolist(),
        "error_probability": {
            "real": result.error_probability_real.tolist(),
            "calculated": result.error_probability_calculated.tolist(),
            "calculated_true_hypothesis": result.error_probability_calculated_true.tolist(),
        },
        "rsd": {
            "real": {k: v.tolist() for k, v in result.rsd_real.items()},
            "calculated": {k: v.tolist() for k, v in result.rsd_calculated.items()},
        },
        "decided": result.decided.tolist(),
        "decided_wrong": result.decided_wrong.tolist(),
        "true_counts": result.true_counts,
        "settings": result.settings,
    }


def write_criteria_json(result: CriteriaResult, path: Path) -> Path:
    """Write ``criteria.json`` (the folder is created)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(criteria_document(result)))
    return path
