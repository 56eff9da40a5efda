"""Maximum-likelihood search of a :class:`~.model.NoiseModel`: per start, ``em_iter`` EM iterations (paper 000 §3)
then L-BFGS-B on the exact likelihood (:mod:`.mle`, beyond the paper), best likelihood kept; GLS means, intervals
(:mod:`.uncertainty`) and a restart from any higher likelihood the profiles meet. Long records with gaps are searched
gap-filled (:data:`.mle.FILL_FIRST_MIN_SAMPLES`) and scored with their gaps."""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ... import kalman
from ...errors import InputError
from ...kalman import statespace as ss
from ...noise.components import RR, Component
from ...noise.modelspec import gauss_markov_fastest_first, model_name, parameter_labels
from ...quality import interpolate_missing
from . import em, mle, whittle
from .results import FitResult
from .uncertainty import Z95, add_uncertainty

if TYPE_CHECKING:
    from .model import FitOptions, NoiseModel

#: Evaluations (with gradient) × samples × states one start's finish may spend, about 30 s (:func:`finish_evaluations`).
FINISH_BUDGET = 3e8
#: The finish's evaluations whatever the budget (a record so long that fewer would be allowed still gets these).
MIN_FINISH_EVALUATIONS = 10


def finish_evaluations(budget: float | None, n: int, states: int) -> int | None:
    """:func:`.mle.evaluations_within` ``budget``, at least :data:`MIN_FINISH_EVALUATIONS`; None without a budget."""
    if budget is None:
        return None
    return max(MIN_FINISH_EVALUATIONS, int(mle.evaluations_within(budget, n, states)))


def _one_start(model: NoiseModel, start: list[Component], y: np.ndarray, options: FitOptions,
               metric_of: Callable[[list[Component]], np.ndarray] | None) -> tuple[mle.MLEResult, int]:
    """(result, EM iterations) of EM then the finish from one start, preconditioned by ``metric_of``; with
    ``em_iter=0`` the finish alone; with neither (``em_iter=0``, no polish) the start scored by one filter pass with
    GLS means."""
    z = model.z
    state = model.statespace(start)
    par = mle.Parameterisation.of(start)
    if options.em_iter == 0 and not options.polish:
        prof = kalman.loglik(state, y, z)
        fitted = kalman.apply_beta(state, prof)
        theta = par.to_theta(ss.to_components(fitted))
        return mle.MLEResult(theta, fitted, prof.loglik, 0, False, "at the start's values", prof), 0
    metric = metric_of(start) if metric_of is not None else None
    metric_at = (lambda fitted: metric_of(ss.to_components(fitted))) if metric_of is not None else None
    finish = functools.partial(mle.maximise, par, y=y, z=z, bounds=model.parameter_bounds, metric=metric,
                               metric_at=metric_at, stop_stalled=options.stop_stalled,
                               max_eval=finish_evaluations(options.finish_budget, y.size, state.phi.shape[0]))
    if options.em_iter == 0:  # the finish alone, from the start with its GLS means (one filter pass, no smoother)
        return finish(kalman.apply_beta(state, kalman.loglik(state, y, z))), 0
    _, state, stats = kalman.profile_and_smooth(state, y, z)  # GLS means and the first E-step in one pass
    em_iter, em_tol = options.em_iter, options.em_tol
    if options.polish:
        # The last EM iterate is scored by the quasi-Newton finish's first evaluation: no E-step for it here.
        run = em.run_em(state, y, z, max_iter=em_iter, tol=em_tol, initial=stats, final_estep=False)
        try:
            res = finish(run.model)
        except (ValueError, np.linalg.LinAlgError):  # InputError is a ValueError
            # That unscored update may have left the filter's domain: redo EM with the check, which keeps the
            # last good iterate (paper 000 §3.5(iii)).
            run = em.run_em(state, y, z, max_iter=em_iter, tol=em_tol, initial=stats)
            res = finish(run.model)
    else:
        run = em.run_em(state, y, z, max_iter=em_iter, tol=em_tol, initial=stats)
        prof = kalman.loglik(run.model, y, z)
        fitted = kalman.apply_beta(run.model, prof)
        theta = par.to_theta(ss.to_components(fitted))
        res = mle.MLEResult(theta, fitted, prof.loglik, 0, run.converged, "EM only", prof)
    return res, run.n_iter


def _mean_parameters(model: NoiseModel, fitted: ss.StateSpace, prof: kalman.ProfileResult,
                     comps: list[Component]) -> dict[str, dict]:
    """Bias, ramp, exog coefficients with GLS se; with ``drift='ls'`` the slope by GLS, appended to ``comps`` as RR."""
    coef: dict[str, dict] = {}
    for name, value, var in zip(prof.names, prof.beta, np.diag(prof.beta_cov), strict=True):
        s_b = math.sqrt(max(float(var), 0.0))
        coef[name.split(":", 1)[1]] = {"value": float(value), "se": s_b, "ci95": (value - Z95 * s_b, value + Z95 * s_b)}
    if model.ls_slope is not None:
        t = model.t
        y_orig = model.y + model.ls_slope[0] * t
        full = ss.from_components([*ss.to_components(fitted), RR(model.ls_slope[0])], model.dt,
                                  exog_names=model.exog_names)
        z_full = np.column_stack([model.z[:, :1], t, model.z[:, 1:]])
        gls = kalman.loglik(full, y_orig, z_full)
        for key in ("ramp", "bias"):
            k = gls.names.index(f"b:{key}")
            value, s_b = float(gls.beta[k]), math.sqrt(max(float(gls.beta_cov[k, k]), 0.0))
            coef[key] = {"value": value, "se": s_b, "ci95": (value - Z95 * s_b, value + Z95 * s_b)}
        coef["ramp"]["ls_value"] = model.ls_slope[0]
        comps.append(RR(coef["ramp"]["value"]))
    return coef


@dataclass(frozen=True)
class _Search:
    """What every start of one fit is searched on: the record (gap-filled if ``fill_first``) and the Whittle metric."""

    y: np.ndarray
    fill_first: bool
    metric_of: Callable[[list[Component]], np.ndarray] | None


def _search_of(model: NoiseModel, options: FitOptions, start_values: list[list[Component]],
               periodogram: whittle.BandedPeriodogram | None, y_av: np.ndarray) -> _Search:
    """The :class:`_Search` of ``model`` (periodogram unbanded around the starts' OSC lines)."""
    bp = periodogram
    if bp is not None and any(c.name == "OSC" for s in start_values for c in s):
        bp = whittle.banded_periodogram(y_av, fine=whittle.line_windows(start_values, model.dt))
    fill_first = model.n_obs < model.n_total and model.n_total > mle.FILL_FIRST_MIN_SAMPLES and options.polish
    y_search = interpolate_missing(model.y) if fill_first else model.y
    metric_of = (functools.partial(whittle.whittle_information, y=y_av, dt=model.dt, periodogram=bp)
                 if bp is not None else None)
    return _Search(y_search, fill_first, metric_of)


def fit_noise_model(model: NoiseModel, init: list[Component] | None, options: FitOptions) -> FitResult:
    """Maximum-likelihood fit of ``model`` (module docstring); InputError when no start gives a likelihood."""
    if init is not None:
        if [c.name for c in init] != model.names:
            raise InputError("init components do not match the structure")
        init = [c for c in init if c.name != "RR"] if model.ls_slope is not None else list(init)
        mle.Parameterisation.of(init).to_theta(init)
    y_av = model.detrended()
    bp = model.banded_periodogram() if options.spectral_init else None
    start_values = [init] if init is not None else model.starting_values(options.n_starts, options.spectral_init, bp)
    search = _search_of(model, options, start_values, bp, y_av)
    best: tuple[mle.MLEResult, int] | None = None
    lls = []
    for start in start_values:
        try:
            res = _one_start(model, start, search.y, options, search.metric_of)
        except (ValueError, np.linalg.LinAlgError):  # InputError is a ValueError
            continue
        lls.append(res[0].loglik)
        if best is None or res[0].loglik > best[0].loglik:
            best = res
    if best is None:
        raise InputError(f"no start of the {'+'.join(model.names)} fit gave a valid likelihood; try init=… values")
    result = _result(model, best, lls, search.fill_first)
    if not options.uncertainty:
        return result
    return _with_intervals(model, result, options, lambda _: search)


def _with_intervals(model: NoiseModel, result: FitResult, options: FitOptions,
                    search_of: Callable[[list[Component]], _Search]) -> FitResult:
    """``result`` with intervals; searched again once from a higher likelihood their profiles met, the better kept."""
    add_uncertainty(result, options.target_precision)
    start = result.better_start
    if start is None:
        return result
    search = search_of(start)
    try:
        again = _one_start(model, start, search.y, options, search.metric_of)
    except (ValueError, np.linalg.LinAlgError):  # InputError is a ValueError
        return result
    if again[0].loglik <= result.loglik:
        return result
    return add_uncertainty(_result(model, again, [*result.starts, again[0].loglik], search.fill_first),
                           options.target_precision)


def add_intervals(model: NoiseModel, result: FitResult, options: FitOptions) -> FitResult:
    """Intervals of a fit made without them, as :func:`fit_noise_model` adds them."""

    def search_of(start: list[Component]) -> _Search:
        bp = model.banded_periodogram() if options.spectral_init else None
        return _search_of(model, options, [start], bp, model.detrended())

    return _with_intervals(model, result, options, search_of)


def _fastest_first(model: NoiseModel, fitted: ss.StateSpace) -> ss.StateSpace:
    """``fitted`` with its GM blocks by increasing τ, GM1 the fastest on every record (beyond paper 000)."""
    comps = ss.to_components(fitted)
    ordered = gauss_markov_fastest_first(comps)
    if all(a is b for a, b in zip(comps, ordered, strict=True)):
        return fitted
    out = model.statespace(ordered)
    out.b, out.b_free = fitted.b.copy(), fitted.b_free.copy()
    return out


def _result(model: NoiseModel, best: tuple[mle.MLEResult, int], lls: list[float], fill_first: bool) -> FitResult:
    """The :class:`FitResult` of the search's best (MLE result, EM iterations), without intervals."""
    res, n_iter = best
    fitted = _fastest_first(model, res.model)
    comps = ss.to_components(fitted)
    # The search's own profile at the optimum unless it ran on the gap-filled record.
    prof = res.profile if res.profile is not None and not fill_first else kalman.loglik(fitted, model.y, model.z)
    exog_coef = _mean_parameters(model, fitted, prof, comps)
    se: dict[str, float] = {}
    ci: dict[str, tuple[float, float]] = {}
    if "ramp" in exog_coef:
        rr_lab = next(lab for i, _, lab in parameter_labels(comps) if comps[i].name == "RR")
        se[rr_lab] = exog_coef["ramp"]["se"]
        ci[rr_lab] = exog_coef["ramp"]["ci95"]
    order = {n: i for i, n in enumerate(model.names)}
    comps = sorted(comps, key=lambda c: order.get(c.name, 99))
    k = model.n_free_noise + model.z.shape[1] + (1 if model.ls_slope is not None else 0)
    ll = float(prof.loglik)
    return FitResult(
        model=model_name(comps), components=comps, exog_coef=exog_coef, se=se, ci95=ci, loglik=ll,
        aic=2 * k - 2 * ll, bic=k * math.log(model.n_obs) - 2 * ll, n=model.n_obs, dt=model.dt, n_iter=n_iter,
        converged=res.converged, n_eval=res.n_eval, n_params=k, starts=lls, statespace=fitted,
        record=(model.y, model.z), standardized=_standardized(prof, model.y.size), budget_stop=res.budget_stop,
    )


def _standardized(prof: kalman.ProfileResult, n: int) -> np.ndarray | None:
    """Standardised innovations of ``prof`` at its GLS means; None when it kept none for all ``n`` samples."""
    if prof.innovations.shape != (n,) or prof.variances.shape != (n,):
        return None
    return prof.innovations / np.sqrt(prof.variances)
