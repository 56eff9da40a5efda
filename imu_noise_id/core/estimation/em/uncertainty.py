"""Standard errors, 95 % intervals (paper 000 §3.4) and record-length advice of a fit: Wald in log space from the
inverse observed information, or profile intervals (:mod:`.profile`, beyond the paper) for every parameter when the
information is not positive definite or one is at its zero boundary, else for those whose log-se exceeds
:data:`WALD_MAX_SE_LOG` or whose Wald ends are outside :data:`WALD_DROP_RANGE`. Past :data:`PROFILE_BUDGET` or
:data:`INFORMATION_BUDGET` the fallback is named in ``ci95_method``."""

from __future__ import annotations

import math

import numpy as np

from ... import kalman
from ...errors import InputError
from ...kalman import statespace as ss
from ...noise.components import RR, Component
from ...noise.modelspec import parameter_labels
from ...noise.resonant import OSC
from ...quality import interpolate_missing
from ..readouts.quantiles import Z95
from . import mle, whittle
from .profile import BudgetSpentError, Profiler
from .results import BUDGET_SPENT, FitResult, RecordLengthAdvice

#: Above this standard error in log space (a 95 % Wald interval wider than ×7 each way) the Wald interval is
#: replaced by a profile-likelihood one.
WALD_MAX_SE_LOG = 1.0
#: The Wald interval stands when ℓ at both its ends on the quadratic trace is this far below the maximum (the
#: signed root within 1.96 − 0.15 … 1.96 + 0.25: a quadratic log-likelihood gives exactly 1.92).
WALD_DROP_RANGE = (0.5 * (Z95 - 0.15) ** 2, 0.5 * (Z95 + 0.25) ** 2)
#: Likelihood evaluations × samples × states the profile intervals of one fit may spend, about 15 s; past it a parameter
#: gets :func:`_beyond_budget`'s interval, its ``ci95_method`` ending in :data:`BUDGET_SPENT`.
PROFILE_BUDGET = 6e8
#: Gradient passes (k + 1) × samples × states the observed information may spend, about 15 s; past it Whittle's
#: expected information (:func:`.whittle.fisher_information`), the Wald method :data:`WHITTLE_WALD`.
INFORMATION_BUDGET = 1.5e8
#: The method of a Wald interval from Whittle's expected information instead of the observed one.
WHITTLE_WALD = "wald (whittle information)"


def profile_evaluations(n: int, states: int) -> float:
    """Exact-likelihood evaluations :data:`PROFILE_BUDGET` allows on ``n`` samples and ``states`` states."""
    return mle.evaluations_within(PROFILE_BUDGET, n, states)


def information(par: mle.Parameterisation, theta: np.ndarray, model: ss.StateSpace, y: np.ndarray, z: np.ndarray, *,
                n: int, dt: float) -> tuple[np.ndarray, str]:
    """(−∂²ℓ/∂ϑ∂ϑᵀ, Wald method name): the observed information (``"wald"``) within :data:`INFORMATION_BUDGET`, else
    Whittle's expected information of ``n`` samples at ``dt`` [s] (:data:`WHITTLE_WALD`)."""
    if theta.size + 1 <= mle.evaluations_within(INFORMATION_BUDGET, np.size(y), model.phi.shape[0]):
        return mle.observed_information(par, theta, model, y, z), "wald"
    return whittle.fisher_information(par.to_components(theta, model), n, dt), WHITTLE_WALD


#: Components whose parameters get their intervals first, while the profile budget lasts: the white noise and the
#: random walk, whose N and K users paste into their filters.
PASTED_FIRST = ("WN", "RW")


def checked_first(labels: list[str]) -> list[int]:
    """Indices of ``labels`` (``WN.noise_density`` …) in the order their intervals spend the profile budget:
    :data:`PASTED_FIRST` components' parameters, then the others, each in the labels' order."""
    return sorted(range(len(labels)), key=lambda k: (labels[k].split(".")[0] not in PASTED_FIRST, k))


def _beyond_budget(v: float, s_log: float, conditional_end: float | None,
                   wald: str = "wald") -> tuple[tuple[float, float], str]:
    """(interval, method) once the budget is spent: (0, conditional upper end) for a zero-boundary parameter
    (``conditional_end`` given: the likelihood cannot tell it from 0, and a Wald interval in log space never reaches
    0), else Wald in log space where the information has one, else (0, ∞)."""
    if conditional_end is not None:
        return (0.0, float(conditional_end)), f"conditional, {BUDGET_SPENT}"
    if math.isfinite(s_log):
        return (v * math.exp(-Z95 * s_log), v * math.exp(Z95 * s_log)), f"{wald}, {BUDGET_SPENT}"
    return (0.0, math.inf), f"not bounded, {BUDGET_SPENT}"


def record_length_advice(
    labels: list[str], cov: np.ndarray, comps: list[Component], n: int, dt: float, *, target: float
) -> RecordLengthAdvice:
    """How long to record for a relative 95 % half-width ``target`` on each parameter ``labels[k]``, from its log
    standard error √cov[k, k] at the record's n·dt [s], assuming se(T) = se(T_now)·√(T_now/T); a GM's advice is a
    lower bound (``reliable`` False) where the duration is below 20 of its τ (``comps`` give τ)."""
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


#: The zero-boundary check's shrink: a parameter this many times smaller that costs less than 1.92 in ℓ is near 0.
NEAR_ZERO_SHRINK = 1e3
#: Records of this many samples or more (where each exact check is a pass over every sample) screen the near-zero
#: checks on the banded Whittle likelihood first (:func:`away_from_zero`).
NEAR_ZERO_SCREEN_SAMPLES = 250_000
#: Whittle log-likelihood drop beyond which a parameter shrunk a thousandfold is away from 0 without its exact check:
#: 26 times the check's 1.92.
NEAR_ZERO_SCREEN_DROP = 50.0
#: Only parameters of components whose memory is below this share of the record are screened: the two likelihoods
#: part far at the lowest frequencies, where the exact one's bias and ramp take a share of a slow component's power
#: (a random walk's drop 135 by Whittle, 2.9 exact; docs/em.md).
NEAR_ZERO_SCREEN_MEMORY = 1e-3
#: ... and lines whose window lies above this many cycles per record (their drops agreed within 20 on weak lines).
NEAR_ZERO_SCREEN_LOWEST = 100.0


def away_from_zero(par: mle.Parameterisation, theta: np.ndarray, model: ss.StateSpace,
                   record: tuple[np.ndarray, np.ndarray], dt: float, *, count: int) -> set[int]:
    """Indices k < ``count`` of the log-parameters ``theta`` of components far from the record's lowest frequencies
    (:func:`_screenable`) whose thousandfold shrink lowers the banded Whittle
    log-likelihood (:func:`.whittle.whittle_loglik`, single frequencies around the model's lines) by more than
    :data:`NEAR_ZERO_SCREEN_DROP`: not near 0, no exact pass needed. The periodogram is of ``record``'s y [u] less its
    regressors z at their values in ``model``, at ``dt`` [s]. Empty below :data:`NEAR_ZERO_SCREEN_SAMPLES` samples or
    with missing samples. Beyond the papers."""
    y, z = record
    if y.size < NEAR_ZERO_SCREEN_SAMPLES or np.isnan(y).any():
        return set()
    comps = par.to_components(theta, model)
    screened = [k for k in range(count) if _screenable(comps[par.entries[k][0]], dt, y.size * dt)]
    if not screened:
        return set()
    noise = y - z @ model.b if z.shape[1] else y
    bp = whittle.banded_periodogram(noise, fine=whittle.line_windows([comps], dt))

    at_estimate = whittle.components_loglik(comps, bp, dt)
    away = set()
    for k in screened:
        shrunk = theta.copy()
        shrunk[k] -= math.log(NEAR_ZERO_SHRINK)
        try:
            drop = at_estimate - whittle.components_loglik(par.to_components(shrunk, model), bp, dt)
        except ValueError:  # outside a component's domain: left to the exact check
            continue
        if drop > NEAR_ZERO_SCREEN_DROP:
            away.add(k)
    return away


def _screenable(c: Component, dt: float, record_s: float) -> bool:
    """Whether ``c`` is white at low frequency (:meth:`~...noise.base.Component.zero_frequency_density`: not a walk,
    not flicker) and either has a memory below :data:`NEAR_ZERO_SCREEN_MEMORY` of the record ``record_s`` [s] or is a
    line whose Whittle window (±20 bandwidths) lies above :data:`NEAR_ZERO_SCREEN_LOWEST` cycles per record."""
    try:
        c.zero_frequency_density(dt)
    except NotImplementedError:
        return False
    if isinstance(c, OSC):
        return c.frequency - 20.0 * c.bandwidth > NEAR_ZERO_SCREEN_LOWEST / record_s
    return c.memory(dt)[0] < NEAR_ZERO_SCREEN_MEMORY * record_s


def _near_zero(par: mle.Parameterisation, res: mle.MLEResult, k: int, y: np.ndarray, z: np.ndarray) -> bool:
    """Whether shrinking parameter k :data:`NEAR_ZERO_SHRINK`-fold lowers ℓ by less than 1.92 (not distinguishable
    from 0)."""
    th = res.theta.copy()
    th[k] -= math.log(NEAR_ZERO_SHRINK)
    try:
        with np.errstate(over="ignore", invalid="ignore"):  # a point that far may overflow: then ℓ is not finite
            ll = kalman.loglik(par.to_model(th, res.model), y, z, innovations=False).loglik
    except (ValueError, np.linalg.LinAlgError):  # InputError is a ValueError
        return False
    return math.isfinite(ll) and res.loglik - ll < mle.LR_DROP_95


def _ramp_regressor(model: ss.StateSpace) -> int | None:
    """Index of the free ramp regressor (RR in measurement mode), or None."""
    if "ramp" in model.regressors:
        j = model.regressors.index("ramp")
        return j if bool(model.b_free[j]) else None
    return None


def add_uncertainty(fit: FitResult, target_precision: float = 0.10) -> FitResult:
    """Standard errors, 95 % intervals and record-length advice of ``fit``, in place (module docstring);
    ``fit.ci95_method`` names each interval's method. InputError when the fit holds no data."""
    if fit.statespace is None or fit.record is None:
        raise InputError("this FitResult holds no data to compute its uncertainty from")
    (y, z), model_ss = fit.record, fit.statespace
    comps_ss = ss.to_components(model_ss)
    par = mle.Parameterisation.of(comps_ss)
    theta = par.to_theta(comps_ss)
    noise_labels = [lab for i, _, lab in parameter_labels(comps_ss) if not isinstance(comps_ss[i], RR)]
    info, wald_method = information(par, theta, model_ss, y, z, n=fit.n, dt=fit.dt)
    cov, fit.information_ok = mle.covariance_from_information(info)
    k_noise = len(noise_labels)
    fit.log_covariance, fit.covariance_labels = cov[:k_noise, :k_noise].copy(), tuple(noise_labels)
    bounds = mle.physical_bounds(np.size(y), fit.dt)
    lo, hi = par.log_bounds(bounds)
    max_eval = profile_evaluations(np.size(y), model_ss.phi.shape[0])
    if np.isnan(y).any() and y.size > mle.FILL_FIRST_MIN_SAMPLES:
        # Profiles need hundreds of evaluations: on a long record with gaps they run on the gap-filled record
        # (the fast engine), an approximation the intervals of such records carry.
        y_fill = interpolate_missing(y)
        prof = Profiler(par, theta, model_ss, y_fill, z, kalman.loglik(model_ss, y_fill, z).loglik, info, lo, hi,
                        max_eval=max_eval)
    else:
        prof = Profiler(par, theta, model_ss, y, z, fit.loglik, info, lo, hi, max_eval=max_eval)
    res = mle.MLEResult(theta, model_ss, fit.loglik, 0, fit.converged, "")
    away = away_from_zero(par, theta, model_ss, (y, z), fit.dt, count=k_noise)
    near_zero = [k for k in range(k_noise) if k not in away and _near_zero(par, res, k, y, z)]
    # An amplitude (a density, a σ) near 0 is at the boundary; a time or frequency (with a physical range) that
    # cannot be told from 0 is merely undetermined.
    zero = [k for k in near_zero if par.entries[k][1] not in bounds]
    prof.zero = {k: prof.conditional_scale(k) for k in zero}
    prof.flat = ({k for k in range(k_noise) if not np.isfinite(cov[k, k])} | set(near_zero)) - set(zero)
    try:
        a_hat = prof.best_at_estimate()
    except BudgetSpentError:
        a_hat = prof.evaluate(theta)[1]

    for k in checked_first(noise_labels):
        lab = noise_labels[k]
        v = float(np.exp(theta[k]))
        s_log = math.sqrt(cov[k, k]) if np.isfinite(cov[k, k]) else math.inf
        fit.se[lab] = v * s_log
        interior = k not in prof.zero and k not in prof.flat
        try:
            wald = interior and s_log <= WALD_MAX_SE_LOG and prof.wald_holds(k, cov, a_hat, WALD_DROP_RANGE)
        except BudgetSpentError:  # checking the Wald interval's ends spends the budget too
            wald = False
        if wald:
            fit.ci95[lab] = (v * math.exp(-Z95 * s_log), v * math.exp(Z95 * s_log))
            fit.ci95_method[lab] = wald_method
        else:
            try:
                if prof.spent:
                    raise BudgetSpentError
                lo_k, hi_k = prof.interval(k, cov)
            except BudgetSpentError:
                fit.ci95[lab], fit.ci95_method[lab] = _beyond_budget(v, s_log, prof.zero.get(k), wald_method)
                continue
            fit.ci95[lab] = (math.exp(lo_k) if math.isfinite(lo_k) else 0.0,
                             math.exp(hi_k) if math.isfinite(hi_k) else math.inf)
            fit.ci95_method[lab] = "profile"
    for table in (fit.se, fit.ci95, fit.ci95_method):  # back in the labels' order
        for lab in noise_labels:
            table[lab] = table.pop(lab)
    j = _ramp_regressor(model_ss)
    rr_lab = next((lab for i, _, lab in parameter_labels(comps_ss) if isinstance(comps_ss[i], RR)), None)
    if j is not None and rr_lab is not None and "ramp" in fit.exog_coef:
        ramp = fit.exog_coef["ramp"]
        fit.ci95_method[rr_lab] = "gls"
        if (prof.zero or prof.flat) and prof.spent:
            fit.ci95_method[rr_lab] = f"gls, {BUDGET_SPENT}"
        elif prof.zero or prof.flat:  # the GLS interval holds the noise parameters; a boundary RW trades with the ramp
            try:
                ramp["ci95"] = prof.slope_interval(j, ramp["value"], ramp["se"])
                fit.ci95[rr_lab] = ramp["ci95"]
                fit.ci95_method[rr_lab] = "profile"
            except BudgetSpentError:
                fit.ci95_method[rr_lab] = f"gls, {BUDGET_SPENT}"
    fit.profile_evaluations = prof.n_eval
    if prof.better is not None:
        fit.better_loglik = prof.better[0]
        fit.better_start = par.to_components(prof.better[1], model_ss)
    fit.record_length = record_length_advice(noise_labels, cov, comps_ss, fit.n, fit.dt, target=target_precision)
    return fit
