"""A fitted GM of short memory as the sensor's low-pass (beyond paper 000): a GM of τ below
:func:`~imu_noise_id.core.noise.resonant.filter_memory_limit` is, to the likelihood, the LPF of cutoff f_c = 1/(2πτ)
[Hz] and passband density N = σ√(2τ); only names change (docs/em.md, "Why: starts"; docs/loop.md, rule 1)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ...errors import InputError
from ...kalman.statespace import to_components
from ...noise.components import GM
from ...noise.modelspec import parameter_labels, structure_name
from ...noise.resonant import LPF, filter_memory_limit
from ..readouts.quantiles import Z95
from .results import FitResult
from .uncertainty import add_uncertainty, record_length_advice


def gm_as_filter(fit: FitResult) -> FitResult:
    """``fit`` with its shortest GM renamed LPF when τ < ``filter_memory_limit(dt)`` and no LPF is present: the
    cutoff's interval is τ's through f_c = 1/(2πτ); the log covariance is carried by ln N = ln σ + ½ ln τ + ½ ln 2,
    ln f_c = −ln τ − ln 2π, giving N a Wald interval and se. Every per-parameter output is labelled as the renamed
    structure's parameters are (:func:`~...noise.modelspec.parameter_labels`: a GM left alone beside the LPF is
    ``GM``, not ``GM2``), the record-length advice recomputed from the carried covariance."""
    gms = [(i, c) for i, c in enumerate(fit.components) if isinstance(c, GM)]
    if not gms or any(isinstance(c, LPF) for c in fit.components):
        return fit
    i, gm = min(gms, key=lambda ic: ic[1].tau)
    if gm.tau >= filter_memory_limit(fit.dt):
        return fit
    components = list(fit.components)
    components[i] = LPF.from_gm(gm.tau, gm.sigma)
    key = "GM" if len(gms) == 1 else f"GM{[j for j, _ in gms].index(i) + 1}"
    se = {k: v for k, v in fit.se.items() if not k.startswith(f"{key}.")}
    ci95 = {k: v for k, v in fit.ci95.items() if not k.startswith(f"{key}.")}
    how = {k: v for k, v in fit.ci95_method.items() if not k.startswith(f"{key}.")}
    if f"{key}.tau" in fit.ci95:
        lo, hi = fit.ci95[f"{key}.tau"]
        ci95["LPF.cutoff"] = (1.0 / (2.0 * math.pi * hi) if hi > 0 else 0.0,
                              1.0 / (2.0 * math.pi * lo) if lo > 0 else math.inf)
        how["LPF.cutoff"] = fit.ci95_method.get(f"{key}.tau", "wald")
    labels, cov = list(fit.covariance_labels), fit.log_covariance
    if f"{key}.sigma" in labels and f"{key}.tau" in labels:
        i_s, i_t = labels.index(f"{key}.sigma"), labels.index(f"{key}.tau")
        # J C Jᵀ with J = I but for the rows ln N = ln σ + ½ ln τ and ln f_c = −ln τ, written out so that the
        # infinite variances of unidentified parameters never meet a zero of J.
        cov = cov.copy()
        cov[[i_s, i_t], :] = np.vstack([cov[i_s] + 0.5 * cov[i_t], -cov[i_t]])
        cov[:, [i_s, i_t]] = np.column_stack([cov[:, i_s] + 0.5 * cov[:, i_t], -cov[:, i_t]])
        labels[i_s], labels[i_t] = "LPF.noise_density", "LPF.cutoff"
        sd = math.sqrt(max(float(cov[i_s, i_s]), 0.0))
        n_lpf = components[i].noise_density
        se["LPF.noise_density"] = n_lpf * sd
        ci95["LPF.noise_density"] = (n_lpf * math.exp(-Z95 * sd), n_lpf * math.exp(Z95 * sd))
        how["LPF.noise_density"] = "wald"
    # the other components keep their values; a GM's tag changes when fewer GMs remain (GM2 → GM)
    renamed = {old: new for (_, _, old), (_, _, new) in zip(parameter_labels(fit.components),
                                                           parameter_labels(components), strict=True)
               if not old.startswith(f"{key}.")}
    se, ci95, how = ({renamed.get(k, k): v for k, v in d.items()} for d in (se, ci95, how))
    labels = [renamed.get(lab, lab) for lab in labels]
    advice = fit.record_length
    if advice is not None and labels:
        advice = record_length_advice(labels, cov, components, fit.n, fit.dt, target=advice.target)
    return replace(fit, model=structure_name([c.name for c in components]), components=components, se=se,
                   ci95=ci95, ci95_method=how, log_covariance=cov, covariance_labels=tuple(labels),
                   record_length=advice)


def with_uncertainty(fit: FitResult) -> FitResult:
    """:func:`.uncertainty.add_uncertainty` on the GM block, then :func:`gm_as_filter` again."""
    if fit.statespace is None:
        raise InputError("this FitResult holds no state space to compute its uncertainty from")
    raw = to_components(fit.statespace)
    as_fitted = replace(fit, model=structure_name([c.name for c in raw]), components=raw, se={}, ci95={},
                        ci95_method={})
    return gm_as_filter(add_uncertainty(as_fitted))
