"""``hypotheses.yaml`` and ``hypotheses_probabilities.csv`` of ``identify`` (decision, probabilities, θ̂ ± RSD), and
identify's console line of an axis, written from the same entry."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..core.axes import UNITS
from ..pipelines.identify import AxisIdentification, Identification
from .numbers import num


def decision_note(entry: AxisIdentification) -> str:
    """On what the axis's decision (or its absence) rests: the probability against γ and any GM hypothesis merged into
    its RW twin (whose raw probability may favour the GM)."""
    final, gamma = entry.result.final, entry.hset.gamma
    merged = final.decision_probabilities
    if final.decision is None:
        best = max(merged, key=merged.__getitem__)
        return f"largest P({best}) = {merged[best]:.3f} < gamma = {gamma:g}"
    note = f"P({final.decision}) = {merged[final.decision]:.3f} >= gamma = {gamma:g}"
    folded = [g for g in final.long_memory if g.twin == final.decision]
    if folded:
        note += "".join(f" with {g.hypothesis} merged into {g.twin} ({g.text()})" for g in folded)
    return note


def decision_line(axis: str, entry: dict[str, Any]) -> str:
    """identify's console line of one axis from its ``hypotheses.yaml`` entry (:func:`axis_entry`), so the two agree."""
    probs = ", ".join(f"{k} {v:.3f}" for k, v in entry["probabilities"].items())
    if entry["decision"] is None:
        return f"{axis}: {probs} -> no decision yet ({entry['decision_note']})"
    return (f"{axis}: {probs} -> decision {entry['decision']} at {entry['decision_time_s']:.3g} s "
            f"({entry['decision_note']})")


def axis_entry(axis: str, entry: AxisIdentification) -> dict[str, Any]:
    """The ``hypotheses.yaml`` entry of one axis: ``decision`` and ``decision_time_s`` both null or both set,
    ``decision_note``, probabilities in [0, 1] summing to 1."""
    result, hset = entry.result, entry.hset
    final = result.final
    time = result.decision_time
    return {
        "unit": UNITS[axis],
        "decision": final.decision,
        "decision_time_s": None if time is None else num(time),
        "decision_note": decision_note(entry),
        "duration_s": num(final.t),
        "probabilities": {k: float(v) for k, v in final.probabilities.items()},
        "decision_probabilities": {k: float(v) for k, v in final.decision_probabilities.items()},
        "indistinguishable": [
            {"hypotheses": [g.hypothesis, *([g.twin] if g.twin else [])], "tau_lower_bound_s": g.tau_lower_bound,
             "record_s": g.record_s, "probability_tau_beyond_half_record": g.probability_long, "note": g.text()}
            for g in final.long_memory
        ],
        "offset_removed": float(entry.offset),
        "warmup_white_noise_estimate": entry.wn_estimate,
        "passes": entry.passes,
        "warmup_s": float(entry.warmup),
        "block": int(hset.block),
        "gamma": float(hset.gamma),
        "hypotheses": {
            name: {
                "probability": est.probability,
                "theta": {k: (None if k in est.not_identifiable else v) for k, v in est.theta.items()},
                "theta_std": {k: (None if k in est.not_identifiable else v) for k, v in est.theta_std.items()},
                "rsd": {k: (None if not np.isfinite(v) or k in est.not_identifiable else v)
                        for k, v in est.rsd.items()},
                "not_identifiable": {k: f"> {v:.6g}" for k, v in est.not_identifiable.items()},
                "state": {s: v[0] for s, v in entry.states[name].items()},
                "state_std": {s: v[1] for s, v in entry.states[name].items()},
                "grid": {p.name: {"range": [p.low, p.high], "n": p.n, "spacing": p.spacing,
                                  "grid_range": [float(p.edges()[0]), float(p.edges()[-1])]}
                         for p in next(h for h in hset.hypotheses if h.name == name).priors},
            }
            for name, est in final.hypotheses.items()
        },
    }


def write_identification(res: Identification, out_dir: Path) -> list[Path]:
    """``hypotheses.yaml`` and ``hypotheses_probabilities.csv`` (probability of each hypothesis vs time)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    doc = {"source_hypotheses": res.source, "dt": res.dt, "notes": list(res.notes),
           "axes": {axis: axis_entry(axis, e) for axis, e in res.axes.items()}}
    yaml_path = out_dir / "hypotheses.yaml"
    yaml_path.write_text(yaml.safe_dump(doc, sort_keys=False))
    lines = ["axis,t_s,hypothesis,probability"]
    for axis, e in res.axes.items():
        r = e.result
        for k, name in enumerate(r.names):
            lines += [f"{axis},{t:.6g},{name},{p:.6g}" for t, p in zip(r.t, r.probabilities[:, k], strict=True)]
    csv_path = out_dir / "hypotheses_probabilities.csv"
    csv_path.write_text("\n".join(lines) + "\n")
    return [yaml_path, csv_path]
