"""Serialise identification results to ``model.yaml``, one entry per axis (``gyro_x`` … ``accel_z``); keys and
units: docs/em.md "``model.yaml``", docs/gmwm.md "``model.yaml`` additions" (:mod:`.gmwm_yaml`), docs/loop.md
"Outputs" (:mod:`.loop_yaml`); ``loglik``, ``aic``, ``bic`` at full precision, null for a GMWM fit."""

from __future__ import annotations

from pathlib import Path

import yaml

from ..core.axes import UNITS
from ..core.estimation.em.mle import RECENT_EVALUATIONS
from ..core.estimation.em.results import FitResult
from ..core.estimation.em.selection import SelectionResult
from ..core.estimation.gmwm.fit import GmwmFit
from ..core.noise.modelspec import parameter_labels
from ..pipelines.analyze.final import FinalModel
from ..pipelines.analyze.models import AxisModel
from ..pipelines.loop import LoopResult
from .gmwm_yaml import comparison_to_dict, gmwm_details, wic_candidates
from .loop_yaml import loop_to_dict
from .numbers import interval, num, num_key


def _component_entry(fit: FitResult, index: int) -> dict:
    comp = fit.components[index]
    labels = {p: lab for i, p, lab in parameter_labels(fit.components) if i == index}
    entry: dict = {"type": comp.name, "estimator": fit.estimator}
    params = comp.params()
    entry.update({k: num(v) for k, v in params.items()})
    se = {p: num(fit.se[lab]) for p, lab in labels.items() if lab in fit.se}
    ci = {p: [num(v) for v in fit.ci95[lab]] for p, lab in labels.items() if lab in fit.ci95}
    how = {p: fit.ci95_method[lab] for p, lab in labels.items() if lab in fit.ci95_method}
    if len(params) == 1:
        if se:
            entry["se"] = next(iter(se.values()))
        if ci:
            entry["ci95"] = next(iter(ci.values()))
        if how:
            entry["ci95_method"] = next(iter(how.values()))
    else:
        if se:
            entry["se"] = se
        if ci:
            entry["ci95"] = ci
        if how:
            entry["ci95_method"] = how
    entry.update({k: num(v) for k, v in comp.per_sample(fit.dt).items()})
    return entry


def fit_to_dict(fit: FitResult, axis: str | None = None, selection: SelectionResult | None = None) -> dict:
    """The ``model.yaml`` entry of one axis."""
    out: dict = {"model": fit.model, "estimator": fit.estimator, "n": int(fit.n), "dt": num(fit.dt)}
    if axis in UNITS:
        out["unit"] = UNITS[axis]
    out["components"] = [_component_entry(fit, i) for i in range(len(fit.components))]
    out["mean"] = {
        k: {"value": num(v["value"]), "se": num(v["se"]), "ci95": [num(c) for c in v["ci95"]],
            **({"ls_value": num(v["ls_value"])} if "ls_value" in v else {})}
        for k, v in fit.exog_coef.items()
    }
    likelihood = fit.estimator == "em"
    out.update({
        **{k: float(getattr(fit, k)) if likelihood else None for k in ("loglik", "aic", "bic")},
        "n_params": int(fit.n_params), "converged": bool(fit.converged), "information_ok": bool(fit.information_ok),
    })
    if fit.short_of_maximum is not None:
        out["short_of_maximum"] = num(fit.short_of_maximum)
    if fit.budget_stop is not None:
        out["finish_stopped_at_budget"] = {"evaluations": int(fit.n_eval), "loglik_rise_last": num(fit.budget_stop),
                                           "over_evaluations": RECENT_EVALUATIONS}
    if isinstance(fit, GmwmFit):
        out["moments"] = gmwm_details(fit)
    if selection is not None:
        out["candidates"] = [{k: (num_key(k, v) if isinstance(v, float) else v) for k, v in row.items()}
                             for row in selection.table]
    if fit.record_length is not None:
        rl = fit.record_length
        out["record_length"] = {
            "target": rl.target, "level": rl.level, "current_s": num(rl.current_s),
            "parameters": {
                lab: {"needed_s": num(rl.needed_s[lab]), "needed_h": num(rl.needed_s[lab] / 3600.0),
                      "relative_halfwidth": num(rl.relative_halfwidth[lab]), "reliable": bool(rl.reliable[lab])}
                for lab in rl.needed_s
            },
        }
    return out


def final_to_dict(final: FinalModel) -> dict:
    """The ``final:`` entry of one axis."""
    fitted = fit_to_dict(final.fit)
    return {
        "source": final.source, "model": final.model, "components": fitted["components"],
        **{name: {"value": None if v.value is None else num(v.value), "ci95": interval(v.ci95), "method": v.method,
                  "source": v.source}
           for name, v in (("noise_density", final.noise_density), ("random_walk", final.random_walk))},
        **({} if final.model_values is None else {"unresolved": final.unresolved, "model_values": {
            name: {"value": None if v.value is None else num(v.value), "ci95": interval(v.ci95), "method": v.method,
                   "source": v.source}
            for name, v in zip(("noise_density", "random_walk"), final.model_values, strict=True)}}),
        "noise_stddev_per_sample": num(final.noise_stddev_per_sample),
        "random_walk_long_tau_bound": {
            "value": num(final.random_walk_bound.value), "level": final.random_walk_bound.level,
            "tau_range": [num(t) for t in final.random_walk_bound.tau_range],
            "simultaneous_over": final.random_walk_bound.estimates,
            "worth_independent_estimates": num(final.random_walk_bound.independent),
            "random_walk_above_it": final.random_walk_above_bound,
            "p_value_of_the_random_walk": (None if final.random_walk.value is None
                                           else num(final.random_walk_bound.p_value(final.random_walk.value)))},
        **{name: {"value": num(b.value), "ci95": interval(b.ci95), "tau_at_minimum":
                  num(b.tau_at_minimum), "reached": bool(b.reached), "source": b.source}
           for name, b in (("bias_instability", final.bias_instability),
                           ("bias_instability_allan", final.bias_instability_allan))},
    }


def _axis_entry(model: AxisModel, axis: str) -> dict:
    """An axis's model-stage entry: its fit, and the GMWM's fit, WIC candidates and the comparison when present."""
    entry = fit_to_dict(model.fit, axis, model.selection)
    if model.gmwm is not None:
        gm = entry if model.fit.estimator == "gmwm" else fit_to_dict(model.gmwm, axis)
        if model.gmwm_selection is not None:
            gm["candidates"] = wic_candidates(model.gmwm_selection)
        if gm is not entry:
            entry["gmwm"] = gm
    if model.comparison is not None:
        entry["agreement"] = comparison_to_dict(model.comparison)
    if model.note:
        entry["note"] = model.note
    return entry


def write_model_yaml(path: Path, models: dict[str, AxisModel], loops: dict[str, LoopResult] | None = None,
                     meta: dict | None = None, finals: dict[str, FinalModel] | None = None) -> Path:
    """Write ``model.yaml``: per axis the model stage's entry (:func:`fit_to_dict`), the loop's steps and the final
    model (an axis with a loop only gets the loop's final model, ``n`` and ``dt``)."""
    loops = loops or {}
    axes: dict = {}
    for axis in dict.fromkeys([*models, *loops]):
        if axis in models:
            entry = _axis_entry(models[axis], axis)
        else:
            loop = loops[axis]
            entry = {"model": loop.final.model, "n": int(loop.n), "dt": num(loop.dt)}
        if axis in loops:
            entry.update(loop_to_dict(loops[axis]))
        if finals and axis in finals:
            entry["final"] = final_to_dict(finals[axis])
        axes[axis] = entry
    doc: dict = {"meta": meta} if meta else {}
    doc["axes"] = axes
    path.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True, width=120))
    return path
