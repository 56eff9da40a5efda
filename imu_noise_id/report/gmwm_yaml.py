"""Serialise GMWM results and the EM-vs-GMWM comparison for ``model.yaml``: a GMWM fit like an EM fit plus
``moments:`` (J-test, misfitting τ, interval methods, wavelet variance, spikes replaced) and ``candidates`` (WIC);
with both estimators ``gmwm:`` and ``agreement:`` (schema: docs/gmwm.md, "``model.yaml`` additions")."""

from __future__ import annotations

import numpy as np

from ..core.estimation.gmwm.fit import GmwmFit
from ..core.estimation.gmwm.select import GmwmSelection
from ..core.estimation.readouts.agreement import MISFIT_Z, Comparison
from .numbers import num


def _nums(a) -> list[float]:
    return [num(v) for v in np.asarray(a, dtype=float)]


def gmwm_details(fit: GmwmFit) -> dict:
    """The ``moments:`` block of a GMWM fit (module docstring)."""
    wv = fit.wv
    out = {"robust": bool(wv.robust) if wv is not None else False, "j_statistic": num(fit.j_statistic),
           "dof": int(fit.dof), "p_value": num(fit.p_value),
           "misfit_tau": [num(t) for t, z in zip(wv.tau, fit.residual_z, strict=False) if abs(z) > MISFIT_Z]
           if wv is not None else [],
           "intervals": dict(fit.interval_method)}
    if wv is not None:
        out["wavelet_variance"] = {"tau": _nums(wv.tau), "nu2": _nums(wv.nu2), "ci95_low": _nums(wv.ci_low),
                                   "ci95_high": _nums(wv.ci_high), "model": _nums(fit.wv_model),
                                   "residual_z": [round(float(z), 3) for z in fit.residual_z]}
        if wv.robust:
            out["spikes_replaced"] = int(wv.n_replaced)
    return out


def wic_candidates(selection: GmwmSelection) -> list[dict]:
    """The WIC table of a GMWM selection."""
    return [{k: (num(v) if isinstance(v, float) else v) for k, v in row.items()} for row in selection.table]


def comparison_to_dict(comparison: Comparison) -> dict:
    """The ``agreement:`` block (module docstring)."""
    return {
        "verdict": comparison.verdict,
        "parameters": [{"quantity": r.quantity, "em": num(r.em), "em_ci95": [num(v) for v in r.em_ci],
                        "gmwm": num(r.gmwm), "gmwm_ci95": [num(v) for v in r.gmwm_ci], "ratio": num(r.ratio),
                        "z": num(r.z), "verdict": r.verdict} for r in comparison.rows],
        "misfit_tau": [num(t) for t in comparison.misfit_tau],
    }
