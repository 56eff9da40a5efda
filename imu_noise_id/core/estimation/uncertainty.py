"""Uncertainty of a fit: standard errors and 95 % intervals (paper 000 §3.4), and how long to record.

The observed information is minus the Hessian of the exact log-likelihood in the log-parameters
(:func:`.mle.observed_information`); intervals are Wald intervals in log space, or likelihood-ratio intervals
(:func:`.mle.likelihood_interval`) where the Wald form is meaningless: a standard error above
:data:`WALD_MAX_SE_LOG` in log space, or a parameter the data cannot tell from 0 (a thousandfold smaller value lowers
the likelihood by less than the 95 % threshold). The recording-length advice scales the per-sample information.
"""

from __future__ import annotations

import math

import numpy as np

from .. import kalman
from ..errors import InputError
from ..kalman import statespace as ss
from ..noise.components import RR, Component
from ..noise.modelspec import parameter_labels
from . import mle
from .results import FitResult, RecordLengthAdvice

#: Two-sided 95 % normal quantile.
Z95 = 1.959963984540054
#: Above this standard error in log space (a 95 % Wald interval wider than ×7 each way) the Wald interval is
#: replaced by a likelihood-ratio one (:func:`.mle.likelihood_interval`).
WALD_MAX_SE_LOG = 1.0


def _record_length(
    labels: list[str], cov: np.ndarray, comps: list[Component], n: int, dt: float, *, target: float
) -> RecordLengthAdvice:
    """Per-sample information = observed information / N, so se(T) = se(T_now)·√(T_now/T)."""
    t_now = n * dt
    needed, half, reliable = {}, {}, {}
    for k, lab in enumerate(labels):
        se_log = math.sqrt(cov[k, k]) if np.isfinite(cov[k, k]) and cov[k, k] >= 0 else math.inf
        half[lab] = Z95 * se_log
        needed[lab] = t_now * (Z95 * se_log / target) ** 2 if math.isfinite(se_log) else math.inf
        reliable[lab] = True
    for lab in labels:
        tag = lab.split(".")[0]
        if tag.startswith("GM"):
            gm = [c for c in comps if c.name == "GM"]
            idx = int(tag[2:]) - 1 if len(tag) > 2 else 0
            tau_c = gm[idx].params()["tau"]
            reliable[lab] = min(t_now, needed[lab]) >= 20.0 * tau_c
    return RecordLengthAdvice(target, "95 % two-sided, relative half-width", t_now, needed, half, reliable)


def _near_zero(par: mle.Parameterisation, res: mle.MLEResult, k: int, y: np.ndarray, z: np.ndarray) -> bool:
    """Whether shrinking parameter k a thousandfold lowers ℓ by less than the 95 % LR threshold (the data
    cannot tell it from 0, so a Wald interval in log space would be wrongly narrow)."""
    th = res.theta.copy()
    th[k] -= math.log(1e3)
    try:
        ll = kalman.loglik(par.to_model(th, res.model), y, z).loglik
    except (ValueError, np.linalg.LinAlgError):  # InputError is a ValueError
        return False
    return res.loglik - ll < mle.LR_DROP_95


def add_uncertainty(fit: FitResult, target_precision: float = 0.10) -> FitResult:
    """Standard errors, 95 % intervals (§3.4) and the recording-length advice of a fit, in place.

    Observed information = minus the Hessian of the exact log-likelihood in log-parameters; Wald intervals
    in log space, likelihood-ratio ones where the parameter cannot be told from 0 or the information is flat.
    """
    if fit.statespace is None or fit.record is None:
        raise InputError("this FitResult holds no data to compute its uncertainty from")
    (y, z), model_ss = fit.record, fit.statespace
    comps_ss = ss.to_components(model_ss)
    par = mle.Parameterisation.of(comps_ss)
    theta = par.to_theta(comps_ss)
    res = mle.MLEResult(theta, model_ss, fit.loglik, 0, fit.converged, "")
    noise_labels = [lab for i, _, lab in parameter_labels(comps_ss) if not isinstance(comps_ss[i], RR)]
    info = mle.observed_information(par, theta, model_ss, y, z)
    cov, fit.information_ok = mle.covariance_from_information(info)
    k_noise = len(noise_labels)
    fit.log_covariance, fit.covariance_labels = cov[:k_noise, :k_noise].copy(), tuple(noise_labels)
    for k, lab in enumerate(noise_labels):
        v = float(np.exp(theta[k]))
        s_log = math.sqrt(cov[k, k]) if np.isfinite(cov[k, k]) else math.inf
        fit.se[lab] = v * s_log
        zero = _near_zero(par, res, k, y, z)
        if s_log <= WALD_MAX_SE_LOG and not zero:
            fit.ci95[lab] = (v * math.exp(-Z95 * s_log), v * math.exp(Z95 * s_log))
        else:
            lo, hi = mle.likelihood_interval(par, theta, k, model_ss, y, z=z, ll_max=fit.loglik, lower=not zero)
            fit.ci95[lab] = (math.exp(lo) if math.isfinite(lo) else 0.0,
                             math.exp(hi) if math.isfinite(hi) else math.inf)
    fit.record_length = _record_length(noise_labels, cov, comps_ss, fit.n, fit.dt, target=target_precision)
    return fit
