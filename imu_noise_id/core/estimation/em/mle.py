"""Quasi-Newton maximum-likelihood finish and information of component models (beyond paper 000; standard errors as
§3.4): L-BFGS-B on the exact log-likelihood in ϑ = log(continuous-time parameters) of the stochastic components, the
mean parameters (bias, ramp, exog, u, μ) profiled by GLS; gradient by Fisher's identity from one smoother pass
(:class:`~.em.MatrixScore`); observed information from differences of that gradient, 95 % intervals
exp(ϑ̂ ± 1.96·se_ϑ), physical se by the delta method."""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import minimize

from ... import kalman
from ...errors import InputError
from ...kalman.common import ProfileResult, check_data
from ...kalman.statespace import StateSpace, state_span, with_components
from ...noise.components import RR, Component
from . import em
from .differences import derivative_in_domain, stepped
from .whittle import with_log_parameters

#: Above this length a record with missing samples is searched (and its intervals profiled) gap-filled.
FILL_FIRST_MIN_SAMPLES = 20_000

#: Metric information −∂²ℓ/∂ϑ_k² below which :func:`maximise` holds log-parameter k at its start (ℓ flat in it).
FLAT_INFORMATION = 1e-3


def physical_bounds(n_total: int, dt: float) -> dict[str, tuple[float, float]]:
    """Ranges searched on ``n_total`` samples at period ``dt`` [s]: GM τ [s] from dt to 100 records; OSC and LPF
    frequencies [Hz] from the record's resolution to Nyquist; OSC bandwidth [Hz] at least two resolution bins."""
    span = n_total * dt
    nyquist = 0.5 / dt
    return {"tau": (dt, 100.0 * span), "frequency": (1.0 / span, nyquist), "bandwidth": (2.0 / span, nyquist),
            "cutoff": (1.0 / span, nyquist)}


@dataclass(frozen=True)
class Parameterisation:
    """Log-parameters of the stochastic components of a structure (RR is a mean parameter, not included)."""

    template: tuple[Component, ...]
    entries: tuple[tuple[int, str], ...]  # (component index, parameter name)

    @classmethod
    def of(cls, components: list[Component]) -> Parameterisation:
        entries = tuple(
            (i, name) for i, c in enumerate(components) if not isinstance(c, RR) for name in c.parameter_names
        )
        return cls(tuple(components), entries)

    @property
    def labels(self) -> list[str]:
        """``'<index>:<type>.<parameter>'`` per entry (index = component position in the structure)."""
        return [f"{i}:{self.template[i].name}.{name}" for i, name in self.entries]

    def to_theta(self, components: list[Component]) -> np.ndarray:
        values = [components[i].params()[name] for i, name in self.entries]
        if any(not (math.isfinite(v) and v > 0) for v in values):
            raise InputError(f"component parameters must be finite and > 0 to fit, got {components}")
        return np.log(values)

    def log_bounds(self, bounds: dict[str, tuple[float, float]]) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) of every log-parameter from physical ``bounds`` by parameter name (±inf where none)."""
        lo, hi = np.full(len(self.entries), -np.inf), np.full(len(self.entries), np.inf)
        for k, (_, name) in enumerate(self.entries):
            if name in bounds:
                lo[k], hi[k] = math.log(bounds[name][0]), math.log(bounds[name][1])
        return lo, hi

    def to_components(self, theta: np.ndarray, model: StateSpace | None = None) -> list[Component]:
        """Components at ϑ (a log-parameter beyond float range gives inf, which the component refuses); RR slopes
        from ``model``'s profiled value when given."""
        out = with_log_parameters(self.template, list(self.entries), theta)
        if model is not None and any(isinstance(c, RR) for c in out):
            from ...kalman.statespace import ramp_components

            # only the RR blocks (docs/em.md, "Why: the maximum-likelihood finish")
            fitted = ramp_components(model)
            out = [fitted[k] if isinstance(c, RR) else c for k, c in enumerate(out)]
        return out

    def to_model(self, theta: np.ndarray, base: StateSpace) -> StateSpace:
        """``base`` with Φ, Q, R at ϑ (mean parameters b, u, μ kept from ``base``)."""
        comps = self.to_components(theta, base)
        return with_components(base, comps)

    def block_derivative(self, component: Component, theta: np.ndarray, k: int, dt: float,
                         step: float) -> tuple[np.ndarray, np.ndarray, float] | None:
        """∂(Φ, Q, R)/∂ϑ_k of the block of ``component`` (the one ϑ_k belongs to) by central differences of ``step``
        (one-sided at a domain edge, :func:`.differences.derivative_in_domain`); None when no step stays inside."""
        name = self.entries[k][1]

        def matrices(h: float) -> np.ndarray:
            block = (replace(component, **{name: float(np.exp(theta[k] + h))}) if h else component).block(dt)
            return np.concatenate([block.phi.ravel(), block.q.ravel(), [block.r]])

        d = derivative_in_domain(matrices, step, lambda: matrices(0.0))
        if d is None:
            return None
        p2 = (d.size - 1) // 2
        p = math.isqrt(p2)
        return d[:p2].reshape(p, p), d[p2:-1].reshape(p, p), float(d[-1])


def loglik_and_grad(
    par: Parameterisation, theta: np.ndarray, base: StateSpace, y: np.ndarray, z: np.ndarray, *,
    step: float = 1e-6, data: em.DataSums | None = None,
) -> tuple[float, np.ndarray, StateSpace]:
    """Profile log-likelihood at ϑ, its exact gradient (Fisher's identity) and the model with GLS means."""
    ll, grad, model, _ = loglik_grad_profile(par, theta, base, y, z, step=step, data=data)
    return ll, grad, model


def loglik_grad_profile(
    par: Parameterisation, theta: np.ndarray, base: StateSpace, y: np.ndarray, z: np.ndarray, *,
    step: float = 1e-6, data: em.DataSums | None = None,
) -> tuple[float, np.ndarray, StateSpace, ProfileResult]:
    """:func:`loglik_and_grad` and the GLS profile (β̂, its covariance): the gradient is :class:`~.em.MatrixScore`
    (one smoother pass) along each log-parameter's change of its own block
    (:meth:`Parameterisation.block_derivative`), or a forward difference of ℓ (:data:`DIFFERENCE_STEP`, one filter
    pass) along a log-parameter whose score entry is not finite (the smoother's sums overflowed at a drive near
    zero)."""
    components = par.to_components(theta, base)
    prof, model, stats = kalman.profile_and_smooth(with_components(base, components), y, z, moments=False)
    score = em.MatrixScore.at(model, stats, data or em.DataSums.of(y, z))
    grad = np.empty(theta.size)
    for k in range(theta.size):
        i = par.entries[k][0]
        change = par.block_derivative(components[i], theta, k, model.dt, step)
        if change is None:
            raise ValueError(f"no step of {step:g} around log-parameter {k} stays inside the components' domains")
        with np.errstate(invalid="ignore"):  # an overflowed entry times a zero change: NaN, read as not finite
            grad[k] = score.directional(state_span(model.blocks[i].states), *change)
        if not math.isfinite(grad[k]):
            grad[k] = _loglik_difference(par, theta, k, base, prof.loglik, y=y, z=z)
    return prof.loglik, grad, model, prof


#: Step [log-parameter] of the forward differences of ℓ where the score's entry is not finite.
DIFFERENCE_STEP = 1e-4


def _loglik_difference(par: Parameterisation, theta: np.ndarray, k: int, base: StateSpace, loglik: float, *,
                       y: np.ndarray, z: np.ndarray) -> float:
    """∂ℓ/∂ϑ_k by a forward difference of :data:`DIFFERENCE_STEP` of the exact log-likelihood from ``loglik`` (ℓ at
    ``theta``): one filter pass. Where it stands in, ℓ is nearly flat along ϑ_k (a block driven to ~0), so the
    step's curvature error, ½·h·∂²ℓ/∂ϑ_k², is small too."""
    moved = theta.copy()
    moved[k] += DIFFERENCE_STEP
    return (kalman.loglik(par.to_model(moved, base), y, z, innovations=False).loglik - loglik) / DIFFERENCE_STEP


@dataclass
class MLEResult:
    """Outcome of :func:`maximise`."""

    theta: np.ndarray
    model: StateSpace
    loglik: float
    n_eval: int
    converged: bool
    message: str
    profile: ProfileResult | None = None  # the GLS profile at ``model`` on the data searched, when kept
    #: ℓ's rise over the last :data:`RECENT_EVALUATIONS` evaluations when ``max_eval`` stopped the search, else None
    budget_stop: float | None = None


def evaluations_within(budget: float, n: int, states: int) -> float:
    """Evaluations a ``budget`` of evaluations × samples × states allows on ``n`` samples and ``states`` states."""
    return budget / (max(int(n), 1) * max(int(states), 1))


#: Evaluations over which a search stopped by its budget reports how fast ℓ still rose.
RECENT_EVALUATIONS = 5
#: A search stopped by its budget whose ℓ rose by less than this over its last :data:`RECENT_EVALUATIONS` evaluations
#: had stalled at its maximum (to this precision of ℓ; its gradient test aside) and is not reported as stopped short.
STALLED_RISE = 1e-2


def _recent_rise(trace: list[float]) -> float:
    """ℓ's rise over the last :data:`RECENT_EVALUATIONS` evaluations of ``trace`` (the best ℓ after each), or over all
    of them when fewer."""
    return float(trace[-1] - trace[max(len(trace) - 1 - RECENT_EVALUATIONS, 0)])


class _StalledError(Exception):
    """ℓ rose by less than :data:`STALLED_RISE` over the last :data:`RECENT_EVALUATIONS` evaluations."""


def maximise(
    par: Parameterisation,
    base: StateSpace,
    y: np.ndarray,
    z: np.ndarray,
    *,
    max_iter: int = 40,
    bounds_width: float = 30.0,
    bounds: dict[str, tuple[float, float]] | None = None,
    grad_tol: float = 1e-2,
    metric: np.ndarray | None = None,
    metric_at: Callable[[StateSpace], np.ndarray] | None = None,
    max_eval: int | None = None,
    stop_stalled: bool = False,
) -> MLEResult:
    """L-BFGS(-B) on the exact profile log-likelihood from ``base`` (e.g. the last EM iterate).

    Parameters
    ----------
    bounds : physical range per parameter name (``tau``, ``frequency``, ``bandwidth``, ``cutoff``);
        others ±``bounds_width``
    grad_tol : stop when every |∂ℓ/∂ϑ| < grad_tol (without ``metric``)
    metric : approximate information −∂²ℓ/∂ϑ² (the Whittle one): the search runs in η = Lᵀ(ϑ − ϑ₀), L Lᵀ = metric, stops
        when every |∂ℓ/∂η| < 0.05, scores a point outside the box at its projection plus a quadratic pull, and holds
        parameters whose information is below :data:`FLAT_INFORMATION` at their start
    metric_at : the metric at another point: a search stopped other than by its gradient test runs once more from its
        end with the metric recomputed there
    max_eval : most evaluations (ℓ with gradient, restart included); when it stops the search while ℓ still rose by
        :data:`STALLED_RISE` or more, ``budget_stop`` is ℓ's rise over the last :data:`RECENT_EVALUATIONS`
    stop_stalled : also stop once ℓ rose by less than :data:`STALLED_RISE` over the last
        :data:`RECENT_EVALUATIONS` evaluations (a refinement from a start already close to the maximum: the gradient
        test of a misspecified model's metric may not be met where ℓ no longer rises); the result is then not
        ``converged``, its message says "stalled", and no restart with ``metric_at`` follows
    """
    from ...kalman.statespace import to_components

    theta0 = par.to_theta(to_components(base))
    lo = theta0 - bounds_width
    hi = theta0 + bounds_width
    for k, (_, name) in enumerate(par.entries):
        if bounds and name in bounds:
            lo[k], hi[k] = math.log(bounds[name][0]), math.log(bounds[name][1])
            theta0[k] = min(max(theta0[k], lo[k]), hi[k])
    state = {"n": 0, "best": (-np.inf, None, None, None), "trace": []}
    y, z = check_data(y, z, base.n_regressors)
    data = em.DataSums.of(y, z)
    scale = max(float(np.sum(np.isfinite(y))), 1.0)
    if metric is not None:
        free = np.diag(metric) > FLAT_INFORMATION
        if not np.any(free):
            free[:] = True
        sub = metric[np.ix_(free, free)]
        w, v = np.linalg.eigh(0.5 * (sub + sub.T))
        w = np.maximum(w, 1e-6 * max(float(np.max(w)), 1e-300))
        T = np.zeros((theta0.size, int(free.sum())))
        T[free] = v / np.sqrt(w)  # ϑ = ϑ₀ + T η  ⇒  Tᵀ metric T = I on the free entries
    else:
        T = np.eye(theta0.size)

    def fun(eta: np.ndarray) -> tuple[float, np.ndarray]:
        raw = theta0 + T @ eta
        theta = np.clip(raw, lo, hi)
        outside = raw - theta
        state["n"] += 1
        try:
            ll, g, model, prof = loglik_grad_profile(par, theta, base, y, z, data=data)
        except (InputError, np.linalg.LinAlgError, ValueError):
            return 1e10, np.zeros_like(eta)
        if not math.isfinite(ll):
            return 1e10, np.zeros_like(eta)
        if ll > state["best"][0]:
            state["best"] = (ll, theta.copy(), model, prof)
        trace = state["trace"]
        trace.append(state["best"][0])
        if stop_stalled and len(trace) > RECENT_EVALUATIONS and _recent_rise(trace) < STALLED_RISE:
            raise _StalledError
        # The likelihood at the projection onto the box, plus a quadratic pull back into it: continuous, so a
        # parameter resting on its bound (an OSC as narrow as the record resolves) does not stall the others.
        g_inside = np.where(outside == 0.0, g, 0.0)
        return -ll / scale + 0.5 * float(outside @ outside), -(T.T @ g_inside) / scale + T.T @ outside

    # With the metric, |∂ℓ/∂η| ≈ √(2 × the gain a Newton step would still bring): 0.05 ⇒ < ~1e-3 left.
    gtol = (0.05 if metric is not None else grad_tol) / scale
    options = {"maxiter": max_iter, "ftol": 1e-15, "gtol": gtol, "maxcor": 20}
    if max_eval is not None:
        options["maxfun"] = max(int(max_eval), 1)
    try:
        res = minimize(fun, np.zeros(T.shape[1]), jac=True, method="L-BFGS-B", options=options)
    except _StalledError:
        res = None
    ll, theta, model, prof = state["best"]
    if theta is None:
        raise InputError("the likelihood could not be evaluated at any parameter value tried")
    if res is None:
        message = (f"stalled: the log-likelihood rose by less than {STALLED_RISE:g} over the last "
                   f"{RECENT_EVALUATIONS} evaluations")
        return MLEResult(theta, model, ll, state["n"], False, message, prof, None)
    converged = float(np.max(np.abs(res.jac), initial=0.0)) <= gtol
    left = None if max_eval is None else max_eval - state["n"]
    rise = _recent_rise(state["trace"])
    budget_stop = None if converged or left is None or left > 0 or rise < STALLED_RISE else rise
    result = MLEResult(theta, model, ll, state["n"], bool(res.success), str(res.message), prof, budget_stop)
    if metric_at is None or metric is None or converged or (left is not None and left <= 0):
        return result
    try:
        again = maximise(par, model, y, z, max_iter=max_iter, bounds_width=bounds_width, bounds=bounds,
                         grad_tol=grad_tol, metric=metric_at(model), max_eval=left)
    except (ValueError, np.linalg.LinAlgError):  # InputError is a ValueError
        return result
    if again.loglik <= result.loglik:
        return replace(result, n_eval=result.n_eval + again.n_eval, budget_stop=again.budget_stop)
    return MLEResult(again.theta, again.model, again.loglik, result.n_eval + again.n_eval, again.converged,
                     again.message, again.profile, again.budget_stop)


def observed_information(
    par: Parameterisation, theta: np.ndarray, model: StateSpace, y: np.ndarray, z: np.ndarray, *,
    step: float = 1e-3, central: bool = False,
) -> np.ndarray:
    """−∂²ℓ/∂ϑ∂ϑᵀ by forward (k + 1 passes, error O(step)) or, with ``central``, central differences (2k passes) of
    the exact gradient, symmetrised; one-sided at a domain edge, a NaN column where no step is possible."""
    k = theta.size
    hess = np.empty((k, k))
    y, z = check_data(y, z, model.n_regressors)
    data = em.DataSums.of(y, z)
    at_theta = functools.cache(lambda: loglik_and_grad(par, theta, model, y, z, data=data)[1])
    for j in range(k):
        d = derivative_in_domain(lambda h, j=j: loglik_and_grad(par, stepped(theta, j, h), model, y, z, data=data)[1],
                                 step, at_theta, central=central)
        hess[:, j] = np.nan if d is None else d
    return -0.5 * (hess + hess.T)


#: Information about a log-parameter beyond this (an sd below 1e-50) is a numerical failure, not knowledge.
MAX_INFORMATION = 1e100


def covariance_from_information(info: np.ndarray) -> tuple[np.ndarray, bool]:
    """(inverse of ``info``, whether it is positive definite). Otherwise parameters with non-finite information or
    above :data:`MAX_INFORMATION`, then those loading most on non-positive directions, are removed until the rest is
    positive definite; removed ones get infinite variance, the others the inverse of their conditional block."""
    k = info.shape[0]
    with np.errstate(invalid="ignore"):
        bad = ~(np.isfinite(info) & (np.abs(info) < MAX_INFORMATION))
    keep = list(range(k))
    while keep and bad[np.ix_(keep, keep)].any():  # the parameter with the most bad entries (a bad diagonal first)
        sub = bad[np.ix_(keep, keep)]
        keep.pop(int(np.argmax(sub.sum(axis=1) + 0.5 * np.diag(sub))))
    while keep:
        sub = info[np.ix_(keep, keep)]
        w, v = np.linalg.eigh(sub)
        scale = max(float(np.max(np.abs(np.diag(sub)))), 1e-300)
        if np.all(w > 1e-10 * scale):
            break
        worst = int(np.argmax(np.abs(v[:, int(np.argmin(w))])))
        keep.pop(worst)
    cov = np.full((k, k), 0.0)
    np.fill_diagonal(cov, np.inf)
    if keep:
        cov[np.ix_(keep, keep)] = np.linalg.inv(info[np.ix_(keep, keep)])
    return cov, len(keep) == k


#: Half the 95 % χ²₁ quantile: a likelihood-ratio interval ends where ℓ drops by this much.
LR_DROP_95 = 1.9207294103470103
