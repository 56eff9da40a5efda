"""Generalized Method of Wavelet Moments (GMWM; Guerrier, Skaloud, Stebler & Victoria-Feser, JASA 108, 2013).

θ̂ = argmin (ν̂ − ν(θ))ᵀ Ω (ν̂ − ν(θ)) (GMWM eq. 3), ν̂ the Haar WV (GMWM eq. 2) or, with ``robust``, the robust WV
(RGMWM; Guerrier, Molinari & Victoria-Feser 2014). Steps: (1) Allan starts (2ν̂ = AV); (2) Ω₁ = diag(edf_j/2ν̂_j²);
(3) Ω₂ = V(θ̂₁)⁻¹, V the exact Gaussian WV covariance (beyond the paper); (4) inference by :mod:`.engine` (sandwich,
GMWM Proposition 2), optionally a parametric bootstrap; an RR's slope from :mod:`.ramp`. Returns :class:`GmwmFit`
(``estimator = "gmwm"``, ``loglik``/``aic``/``bic`` NaN)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ...errors import InputError
from ...kalman import statespace as ss
from ...noise.components import COMPONENT_TYPES, RR, Component, simulate_sum
from ...noise.modelspec import CANONICAL_ORDER, gauss_markov_fastest_first, model_name
from ...noise.trend import ls_slope
from ...quality import interpolate_missing
from ...wavelet.robust import DEFAULT_EFFICIENCY
from ...wavelet.variance import DEFAULT_MAX_FRACTION, WaveletVariance, wavelet_variance
from ..em.model import check_signal, parse_structure_or_components
from ..em.results import FitResult
from ..em.starts import fit_allan
from ..em.uncertainty import record_length_advice
from ..readouts.quantiles import Z95
from . import engine as eng
from .ramp import fit_ramp


@dataclass(frozen=True)
class GmwmOptions:
    """How :func:`fit_gmwm` estimates: ``robust`` WV (biweight M-estimator of Gaussian ``efficiency``), scales up to
    ``max_fraction``·N, ``n_starts`` Allan starts, ``bootstrap`` parametric-bootstrap replicates (0: asymptotic
    intervals) with ``seed``, ``target_precision`` the relative 95 % half-width of the record-length advice."""

    robust: bool = False
    efficiency: float = DEFAULT_EFFICIENCY
    max_fraction: float = DEFAULT_MAX_FRACTION
    n_starts: int = 3
    bootstrap: int = 0
    seed: int = 0
    target_precision: float = 0.10

    def __post_init__(self) -> None:
        if self.n_starts < 1 or self.bootstrap < 0:
            raise InputError(f"n_starts must be >= 1 and bootstrap >= 0, got {self.n_starts}, {self.bootstrap}")


@dataclass
class GmwmFit(FitResult):
    """A GMWM fit: :class:`FitResult` plus the wavelet moments.

    Attributes
    ----------
    wv, wv_model, wv_covariance : the WV fitted (classical or robust); ν(θ̂) and V(θ̂) at its scales
    j_statistic, dof, p_value : J-test of the model (χ² with ``dof`` degrees of freedom when it holds)
    residual_z : (ν̂ − ν(θ̂)) / sd per scale (|z| > 2: misfit)
    wic_penalty : 2·tr(Ω A H⁻¹ Aᵀ Ω V) (WIC = J + penalty under the fit's own weight)
    interval_method : per parameter label, how its interval was obtained
    """

    wv: WaveletVariance | None = field(default=None, repr=False)
    wv_model: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    wv_covariance: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)), repr=False)
    j_statistic: float = math.nan
    dof: int = 0
    p_value: float = math.nan
    residual_z: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    wic_penalty: float = math.nan
    interval_method: dict[str, str] = field(default_factory=dict)


def canonical_order(components: list[Component]) -> list[Component]:
    """Components in canonical order, Gauss–Markov processes by increasing τ (GM1 the fastest)."""
    rank = {n: i for i, n in enumerate(CANONICAL_ORDER)}
    return gauss_markov_fastest_first(sorted(components, key=lambda c: rank.get(c.name, 99)))


def _with_ramp_start(components: list[Component], wv: WaveletVariance) -> list[Component]:
    """RR's start: the slope whose WV (ω·τ/2)² makes up the longest scale's excess over the other components."""
    if not any(isinstance(c, RR) for c in components):
        return components
    others = [c for c in components if not isinstance(c, RR)]
    excess = float(wv.nu2[-1] - (eng.theoretical_wv(others, wv.tau[-1:], wv.dt)[0] if others else 0.0))
    slope = 2.0 * math.sqrt(max(excess, 1e-6 * wv.nu2[-1])) / wv.tau[-1]
    return [RR(slope) if isinstance(c, RR) else c for c in components]


def starting_values(names: list[str], wv: WaveletVariance, n_starts: int) -> list[list[Component]]:
    """Up to ``n_starts`` distinct starts from the Allan-variance fit of the WV (2ν̂ is the AV)."""
    fits = fit_allan(names, wv.as_allan(), wv.dt)
    return [_with_ramp_start(list(c), wv) for _, c in fits[:n_starts]]


@dataclass
class Estimate:
    """The efficient GMWM estimate of one structure on one or several records, before :func:`dress`."""

    problem: eng.Problem
    best: eng.Minimum
    inference: eng.Inference
    covariances: list[np.ndarray]
    start_objectives: list[float]

    @property
    def components(self) -> list[Component]:
        return self.problem.par.to_components(self.best.theta)

    def wic(self, weights: eng.Weights) -> float:
        """WIC = J + 2·tr(Ω A H⁻¹ Aᵀ Ω V) of this structure refitted under ``weights`` (Guerrier et al. 2015), the
        weight structures are compared under."""
        problem = self.problem.with_weights(weights)
        best = problem.minimise(self.best.theta)
        return best.objective + eng.infer(problem, best, list(weights.covariance)).optimism


def estimate(runs: list[eng.Moments], starts: list[list[Component]]) -> Estimate:
    """Steps 2–4 on the records ``runs`` (one θ for all); InputError without starts."""
    if not starts:
        raise InputError("no starting values for the GMWM fit")
    par = eng.Parameters.of(canonical_order(starts[0]))
    theta0 = par.to_theta(list(par.template))
    problem = eng.Problem(par, runs, eng.Weights.diagonal(runs), par.bounds(theta0, runs))
    results = []
    for start in starts:
        ordered = canonical_order(start)
        if [c.name for c in ordered] == [c.name for c in par.template]:
            results.append(problem.minimise(par.to_theta(ordered)))
    first = min(results, key=lambda r: r.objective)
    problem = problem.with_weights(eng.Weights.at(runs, par.to_components(first.theta)))
    best = problem.minimise(first.theta)
    # The components in canonical order at θ̂ (two GMs may have swapped), and the search box around them.
    comps = canonical_order(par.to_components(best.theta))
    par = eng.Parameters.of(comps)
    theta = par.to_theta(comps)
    problem = eng.Problem(par, runs, problem.weights, par.bounds(theta, runs))
    best = replace(best, theta=theta)
    move = float(np.max(np.abs(best.theta - first.theta)))
    covs = list(problem.weights.covariance) if move < 0.02 else [run.covariance(comps) for run in runs]
    return Estimate(problem, best, eng.infer(problem, best, covs), covs, [r.objective for r in results])


def intervals(est: Estimate) -> tuple[dict[str, float], dict[str, tuple[float, float]], dict[str, str]]:
    """(se, 95 % interval, method) per parameter: Wald in log space, or the objective's profile (χ²₁) where the
    log-sd exceeds ``WALD_MAX_SE_LOG``, the amplitude is indistinguishable from 0 or at its bound."""
    se, ci, how = {}, {}, {}
    cov = est.inference.covariance
    for k, lab in enumerate(est.problem.par.labels):
        value = float(np.exp(est.best.theta[k]))
        sd = math.sqrt(cov[k, k]) if np.isfinite(cov[k, k]) and cov[k, k] >= 0 else math.inf
        se[lab] = value * sd
        zero = eng.near_zero(est.problem, est.best, k)
        if sd <= eng.WALD_MAX_SE_LOG and not zero and not est.best.at_bound[k]:
            ci[lab] = (value * math.exp(-Z95 * sd), value * math.exp(Z95 * sd))
            how[lab] = "wald (sandwich covariance, log scale)"
            continue
        lo, hi = eng.profile_interval(est.problem, est.best, k, lower=not zero)
        if est.problem.par.entries[k][1] not in eng.AMPLITUDES:  # τ, frequencies: unbounded means the search range
            lo, hi = (v if math.isfinite(v) else edge for v, edge in zip((lo, hi), est.problem.box_of(k), strict=True))
        ci[lab] = (math.exp(lo) if math.isfinite(lo) else 0.0, math.exp(hi) if math.isfinite(hi) else math.inf)
        how[lab] = "profile of the GMWM objective (chi2_1)" + (": indistinguishable from 0" if zero else "")
    return se, ci, how


def _with_slope(components: list[Component], slope: float | None) -> list[Component]:
    """The components with the RR's slope set to ``slope`` (signed; None keeps the WV's |ω|)."""
    return [RR(slope) if isinstance(c, RR) and slope is not None else c for c in components]


def _bootstrap(est: Estimate, options: GmwmOptions, slope: float | None) -> dict[str, np.ndarray]:
    """Parametric bootstrap of the log-parameters: records simulated from θ̂, their WV refitted with Ω₂."""
    run = est.problem.runs[0].wv
    rng = np.random.default_rng(options.seed)
    comps = _with_slope(est.components, slope)
    draws = []
    for _ in range(options.bootstrap):
        y = simulate_sum(comps, run.n, run.dt, rng)
        wv = wavelet_variance(y, run.dt, robust=run.robust, efficiency=options.efficiency, m=run.m)
        sim = eng.Problem(est.problem.par, [eng.Moments(wv)], est.problem.weights, est.problem.box)
        draws.append(sim.minimise(est.best.theta).theta)
    return {lab: np.exp(np.array(draws)[:, k]) for k, lab in enumerate(est.problem.par.labels)}


def dress(est: Estimate, *, n: int, dt: float, options: GmwmOptions, slope: float | None = None,
          uncertainty: bool = True) -> GmwmFit:
    """The :class:`GmwmFit` of ``est`` (intervals, bootstrap and advice unless not ``uncertainty``); ``slope``: the
    record's least-squares slope [u/s] for an RR (:mod:`.ramp`), None keeps the WV's |ω|."""
    se, ci, how = intervals(est) if uncertainty else ({}, {}, {})
    if options.bootstrap and uncertainty:
        for lab, values in _bootstrap(est, options, slope).items():
            ci[lab] = tuple(float(v) for v in np.quantile(values, [0.025, 0.975]))
            se[lab] = float(np.std(values, ddof=1))
            how[lab] = f"parametric bootstrap ({options.bootstrap} records)"
    rr_lab = next((lab for lab in est.problem.par.labels if lab.startswith("RR")), None)
    if rr_lab is not None and slope is not None and uncertainty:
        ramp = fit_ramp(est.problem, est.best.theta, slope, n, dt)
        slope, se[rr_lab], ci[rr_lab] = ramp.slope, ramp.se, ramp.ci95
        how[rr_lab] = "profile of the WV moments joined with the least-squares slope (chi2_1)"
    comps = _with_slope(est.components, slope)
    cov = est.inference.covariance
    labels = list(est.problem.par.labels)
    run = est.problem.runs[0]
    return GmwmFit(
        model=model_name(comps), components=comps, exog_coef={}, se=se, ci95=ci, loglik=math.nan, aic=math.nan,
        bic=math.nan, n=n, dt=dt, n_iter=est.best.n_eval, converged=est.best.converged,
        record_length=record_length_advice(labels, cov, comps, n, dt, target=options.target_precision) if uncertainty
        else None,
        information_ok=est.inference.identified, n_eval=est.best.n_eval, n_params=len(labels),
        starts=list(est.start_objectives), log_covariance=cov, covariance_labels=tuple(labels), estimator="gmwm",
        wv=run.wv, wv_model=run.model(est.components), wv_covariance=est.covariances[0],
        j_statistic=est.inference.j_statistic, dof=est.inference.dof, p_value=est.inference.p_value,
        residual_z=est.inference.residual_z[0], wic_penalty=est.inference.optimism, interval_method=how,
    )


def prepare(y: np.ndarray, dt: float, options: GmwmOptions) -> tuple[WaveletVariance, float]:
    """The WV of a record (gaps filled first) and its least-squares slope [u/s] (of the samples observed)."""
    y = check_signal(y, dt)
    slope = ls_slope(y, dt)
    wv = wavelet_variance(interpolate_missing(y), dt, robust=options.robust, efficiency=options.efficiency,
                          max_fraction=options.max_fraction)
    return wv, slope


def estimate_structure(wv: WaveletVariance, structure: str | list[Component], *, options: GmwmOptions,
                       init: list[Component] | None = None, more_starts: tuple[list[Component], ...] = ()) -> Estimate:
    """The GMWM estimate of one structure on one record's WV, before intervals (:func:`fit_gmwm`); ``more_starts``:
    further starting components, each searched under the first step's weight (:func:`estimate`)."""
    names, given = parse_structure_or_components(structure)
    ss.validate_structure(names)
    n_params = sum(len(COMPONENT_TYPES[n].parameter_names) for n in names)
    if wv.m.size <= n_params:
        raise InputError(f"{wv.m.size} wavelet scales are too few for the {n_params} parameters of "
                         f"{'+'.join(names)}: record longer or choose a simpler model")
    start = init or given
    starts = ([_with_ramp_start(list(start), wv)] if start is not None
              else starting_values(names, wv, options.n_starts))
    return estimate([eng.Moments(wv)], starts + [_with_ramp_start(list(c), wv) for c in more_starts])


def fit_gmwm(y: np.ndarray | None, dt: float, structure: str | list[Component], *,
             options: GmwmOptions | None = None, init: list[Component] | None = None,
             wv: WaveletVariance | None = None, slope: float | None = None) -> GmwmFit:
    """GMWM fit of one structure to one axis; InputError on a bad signal or structure, too few scales for the
    parameters, or no start that fits.

    Parameters
    ----------
    y : samples [u] at period ``dt`` [s] (NaN filled by interpolation), or None with ``wv``
    structure : ``'WN+GM+RW'``, a spec with values or components (then the start)
    init : starting components instead of the Allan starts
    wv, slope : the record's WV and least-squares slope [u/s] (:func:`prepare`), when the caller has them
    """
    options = options or GmwmOptions()
    if wv is None:
        if y is None:
            raise InputError("fit_gmwm needs the samples y or their wavelet variance wv")
        wv, slope = prepare(y, dt, options)
    est = estimate_structure(wv, structure, options=options, init=init)
    return dress(est, n=wv.n, dt=wv.dt, options=options, slope=slope)
