"""The GMWM's numerical engine over one or several records (GMWM: Guerrier et al., JASA 108, 2013; several records:
MGMWM, Bakalli et al., "Multi-signal approaches for repeated sampling schemes in inertial sensor calibration"):

    θ̂ = argmin_θ Σ_k (ν̂_k − ν_k(θ))ᵀ Ω_k (ν̂_k − ν_k(θ))                             (GMWM eq. 3)

over log-parameters θ. With A_k = ∂ν_k/∂θᵀ, H = Σ A_kᵀΩ_kA_k, S = Σ A_kᵀΩ_kV_kΩ_kA_k: Ξ = H⁻¹ S H⁻¹ (GMWM Proposition
2); at the efficient weight the minimum is Hansen's J, χ²(Σ J_k − p), and the profiled objective's rise is χ²₁ (Newey
& West 1987). WIC penalty 2 Σ tr(Ω_k A_k H⁻¹ A_kᵀ Ω_k V_k) (Guerrier et al. 2015), 2p when efficient."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import linalg
from scipy.optimize import least_squares

from ...noise.components import Component
from ...noise.modelspec import parameter_labels
from ...wavelet.covariance import narrowest_line, theoretical_wv, wv_covariance
from ...wavelet.variance import WaveletVariance
from ..em.differences import derivative_in_domain, stepped
from ..em.mle import covariance_from_information, physical_bounds
from ..readouts.quantiles import CHI2_95

#: Parameters whose value scales a component's variance (may be indistinguishable from 0).
AMPLITUDES = frozenset({"noise_density", "random_walk", "sigma", "Q", "slope"})
#: Half-width [log units] of the search box of amplitudes around their start.
AMPLITUDE_WIDTH = 30.0
#: A component whose WV is below this share of the data's at every scale is at its ~0 boundary.
WV_FLOOR = 1e-8
#: Above this standard error of a log-parameter a Wald interval is replaced by a profile one.
WALD_MAX_SE_LOG = 1.0


@dataclass(frozen=True)
class Parameters:
    """Log-parameters θ of a structure: every parameter of every component (an RR's |slope| included)."""

    template: tuple[Component, ...]
    entries: tuple[tuple[int, str], ...]
    labels: tuple[str, ...]
    base: tuple[dict[str, float], ...]  # the template's parameters (asdict is slow: read once)

    @classmethod
    def of(cls, components: list[Component]) -> Parameters:
        labels = parameter_labels(list(components))
        return cls(tuple(components), tuple((i, p) for i, p, _ in labels), tuple(lab for *_, lab in labels),
                   tuple(c.params() for c in components))

    def to_theta(self, components: list[Component]) -> np.ndarray:
        return np.log([abs(components[i].params()[p]) for i, p in self.entries])

    def to_components(self, theta: np.ndarray) -> list[Component]:
        """Components at θ (ValueError when θ leaves a component's domain, e.g. an OSC too damped)."""
        params = [dict(b) for b in self.base]
        for (i, p), v in zip(self.entries, theta, strict=True):
            params[i][p] = float(np.exp(v))
        return [type(c)(**kw) for c, kw in zip(self.template, params, strict=True)]

    def bounds(self, theta0: np.ndarray, runs: list[Moments]) -> tuple[np.ndarray, np.ndarray]:
        """Search box: physical ranges for τ and frequencies (:func:`physical_bounds`), an OSC's bandwidth from
        :func:`~imu_noise_id.core.wavelet.covariance.narrowest_line` (or its start, if narrower); amplitudes ±30
        e-folds, the lower end raised to where the component's WV is below :data:`WV_FLOOR` of the data's at every
        scale."""
        n, dt = max(r.wv.n for r in runs), runs[0].wv.dt
        phys = physical_bounds(n, dt)
        lo, hi = theta0 - AMPLITUDE_WIDTH, theta0 + AMPLITUDE_WIDTH
        comps = self.to_components(theta0)
        for k, (i, p) in enumerate(self.entries):
            if p in phys:
                lo[k], hi[k] = math.log(phys[p][0]), math.log(phys[p][1])
                if p == "bandwidth":  # a line narrower than this makes each covariance take minutes (start inside)
                    floor = narrowest_line(comps[i].frequency, n, dt)
                    lo[k] = min(max(lo[k], math.log(floor)), theta0[k]) if floor > 0 else lo[k]
            elif p in AMPLITUDES:
                ratio = min(float(np.min(r.wv.nu2 / np.maximum(r.model([comps[i]]), 1e-300))) for r in runs)
                if math.isfinite(ratio) and ratio > 0:  # the WV of an amplitude scales with its square
                    lo[k] = max(lo[k], min(theta0[k] + 0.5 * math.log(WV_FLOOR * ratio), theta0[k] - 1.0))
        return lo, hi


@dataclass(frozen=True)
class Moments:
    """The WV of one record: what the objective compares the model with."""

    wv: WaveletVariance

    def model(self, components: list[Component]) -> np.ndarray:
        return theoretical_wv(components, self.wv.tau, self.wv.dt)

    def covariance(self, components: list[Component]) -> np.ndarray:
        return wv_covariance(components, self.wv.m, self.wv.n, self.wv.dt, scale=self.wv.scale)


@dataclass(frozen=True)
class Weights:
    """Ω_k = V_k⁻¹ of each record through the whitening matrices L_k⁻¹ (V_k = L_k L_kᵀ), and the V_k themselves."""

    whiten: tuple[np.ndarray, ...]
    covariance: tuple[np.ndarray, ...]

    @classmethod
    def at(cls, runs: list[Moments], components: list[Component]) -> Weights:
        covs = [run.covariance(components) for run in runs]
        return cls(tuple(_inverse_cholesky(v) for v in covs), tuple(covs))

    @classmethod
    def diagonal(cls, runs: list[Moments]) -> Weights:
        """First-step weight: each scale's variance 2ν̂²/edf (χ² law; the gmwm package's "fast" choice)."""
        covs = [np.diag(2.0 * run.wv.nu2**2 / run.wv.edf) for run in runs]
        return cls(tuple(np.diag(1.0 / np.sqrt(np.diag(v))) for v in covs), tuple(covs))

    def omega(self, k: int) -> np.ndarray:
        return self.whiten[k].T @ self.whiten[k]


#: Smallest eigenvalue, relative to the largest, of the correlation matrix a weight is built from.
EIGENVALUE_FLOOR = 1e-10


def _inverse_cholesky(v: np.ndarray) -> np.ndarray:
    """L⁻¹ with V = L Lᵀ, through the correlation matrix; one not positive definite is first projected (Higham 2002,
    one step: eigenvalues clipped at :data:`EIGENVALUE_FLOOR` of the largest, unit diagonal restored)."""
    d = np.sqrt(np.diag(v))
    corr = v / np.outer(d, d)
    try:
        chol = linalg.cholesky(corr, lower=True)
    except linalg.LinAlgError:
        w, vec = np.linalg.eigh(0.5 * (corr + corr.T))
        w = np.maximum(w, EIGENVALUE_FLOOR * max(float(w.max()), 1e-300))
        fixed = (vec * w) @ vec.T
        scale = np.sqrt(np.diag(fixed))
        chol = linalg.cholesky(fixed / np.outer(scale, scale), lower=True)
    return linalg.solve_triangular(chol, np.eye(d.size), lower=True) / d[None, :]


@dataclass(frozen=True)
class Minimum:
    theta: np.ndarray
    objective: float
    n_eval: int
    converged: bool
    at_bound: np.ndarray


@dataclass(frozen=True)
class Problem:
    """The objective of GMWM eq. 3: parameters, records, weights and the search box."""

    par: Parameters
    runs: list[Moments]
    weights: Weights
    box: tuple[np.ndarray, np.ndarray]

    def box_of(self, k: int) -> tuple[float, float]:
        """The search range of log-parameter k."""
        return float(self.box[0][k]), float(self.box[1][k])

    def with_weights(self, weights: Weights) -> Problem:
        return Problem(self.par, self.runs, weights, self.box)

    def residuals(self, theta: np.ndarray) -> np.ndarray:
        """Whitened moment residuals L_k⁻¹(ν̂_k − ν_k(θ)), stacked (their squared norm is the objective)."""
        try:
            comps = self.par.to_components(theta)
        except ValueError:
            return np.full(sum(r.wv.m.size for r in self.runs), 1e8)
        return np.concatenate([w @ (run.wv.nu2 - run.model(comps))
                               for run, w in zip(self.runs, self.weights.whiten, strict=True)])

    def residual_jacobian(self, theta: np.ndarray) -> np.ndarray:
        """−L_k⁻¹A_k stacked (:func:`jacobian`); zero where θ leaves a component's domain."""
        try:
            return -np.vstack([w @ jacobian(self.par, theta, run)
                               for run, w in zip(self.runs, self.weights.whiten, strict=True)])
        except ValueError:
            return np.zeros((sum(r.wv.m.size for r in self.runs), theta.size))

    def objective(self, theta: np.ndarray) -> float:
        r = self.residuals(theta)
        return float(r @ r)

    def minimise(self, theta0: np.ndarray, free: np.ndarray | None = None,
                 box: tuple[np.ndarray, np.ndarray] | None = None, tol: float = 1e-10) -> Minimum:
        """Trust-region least squares of the whitened residuals over the ``free`` entries (others held) in ``box``."""
        lo, hi = box or self.box
        free = np.ones(theta0.size, bool) if free is None else free
        base = np.clip(theta0, lo + 1e-9, hi - 1e-9)

        def full(x: np.ndarray) -> np.ndarray:
            th = base.copy()
            th[free] = x
            return th

        sol = least_squares(lambda x: self.residuals(full(x)), base[free],
                            jac=lambda x: self.residual_jacobian(full(x))[:, free], bounds=(lo[free], hi[free]),
                            method="trf", x_scale="jac", xtol=tol, ftol=tol * 1e-2, gtol=tol,
                            max_nfev=100 * (int(free.sum()) + 1))
        theta = full(sol.x)
        at_bound = np.zeros(theta.size, bool)
        at_bound[free] = (sol.x <= lo[free] + 1e-6) | (sol.x >= hi[free] - 1e-6)
        return Minimum(theta, 2.0 * float(sol.cost), int(sol.nfev), bool(sol.status > 0), at_bound)

    def profile(self, best: Minimum, k: int, value: float, box: tuple[np.ndarray, np.ndarray] | None = None) -> float:
        """Rise of the objective, minimised over the others, with log-parameter k held at ``value``."""
        th = best.theta.copy()
        th[k] = value
        free = np.ones(th.size, bool)
        free[k] = False
        low = self.objective(th) if not free.any() else self.minimise(th, free, box, tol=1e-7).objective
        return low - best.objective


def log_gradient(par: Parameters, theta: np.ndarray, of_component: Callable[[Component], np.ndarray | float],
                 step: float = 1e-5) -> np.ndarray:
    """∂/∂θᵀ (…, p) of Σ_c f(c), f additive over components and ∝ each amplitude² (a WV, the LS slope's variance):
    2f(c) for amplitudes, central differences of the own component's f otherwise; ValueError outside a domain."""
    comps = par.to_components(theta)
    parts = [np.asarray(of_component(c), dtype=float) for c in comps]
    out = np.zeros((*parts[0].shape, theta.size))
    for k, (i, name) in enumerate(par.entries):
        if name in AMPLITUDES:
            out[..., k] = 2.0 * parts[i]
            continue
        d = derivative_in_domain(lambda h, i=i, k=k: of_component(par.to_components(stepped(theta, k, h))[i]), step,
                                 lambda i=i: parts[i])
        if d is not None:
            out[..., k] = d
    return out


def jacobian(par: Parameters, theta: np.ndarray, run: Moments) -> np.ndarray:
    """A = ∂ν/∂θᵀ (J × p) in the log-parameters; ValueError outside a domain."""
    return log_gradient(par, theta, lambda c: run.model([c]))


@dataclass(frozen=True)
class Inference:
    """Sandwich covariance and goodness of fit at a minimum.

    Attributes
    ----------
    covariance : Ξ of the log-parameters (inf on the diagonal of unidentified parameters)
    identified : H positive definite with no parameter on its bound
    j_statistic, dof, p_value : the minimum, Σ J_k − p and P(χ² > J)
    optimism : WIC penalty 2 Σ tr(Ω_k A_k H⁻¹ A_kᵀ Ω_k V_k)
    residual_z : per record, (ν̂ − ν(θ̂)) / sd of that residual
    """

    covariance: np.ndarray
    identified: bool
    j_statistic: float
    dof: int
    p_value: float
    optimism: float
    residual_z: tuple[np.ndarray, ...]


def infer(problem: Problem, best: Minimum, covariances: list[np.ndarray]) -> Inference:
    """Ξ = H⁻¹SH⁻¹ (V_k = ``covariances`` at θ̂), the J-test and the residual z."""
    from scipy.stats import chi2

    par, runs, weights = problem.par, problem.runs, problem.weights
    p = best.theta.size
    jac = [jacobian(par, best.theta, run) for run in runs]
    omegas = [weights.omega(k) for k in range(len(runs))]
    h = sum(a.T @ o @ a for a, o in zip(jac, omegas, strict=True))
    s = sum(a.T @ o @ v @ o @ a for a, o, v in zip(jac, omegas, covariances, strict=True))
    keep = ~best.at_bound
    h_inv = np.zeros((p, p))
    sub, ok = covariance_from_information(h[np.ix_(keep, keep)])
    h_inv[np.ix_(keep, keep)] = np.where(np.isfinite(sub), sub, 0.0)
    finite = np.zeros(p, bool)
    finite[np.flatnonzero(keep)[np.isfinite(np.diag(sub))]] = True
    cov = np.full((p, p), 0.0)
    cov[np.ix_(finite, finite)] = (h_inv @ s @ h_inv)[np.ix_(finite, finite)]
    cov[~finite, ~finite] = np.inf
    optimism = 2.0 * sum(float(np.trace(o @ a @ h_inv @ a.T @ o @ v))
                         for a, o, v in zip(jac, omegas, covariances, strict=True))
    z = []
    for a, o, v in zip(jac, omegas, covariances, strict=True):
        g = h_inv @ a.T @ o @ v
        resid_cov = v - a @ g - g.T @ a.T + a @ np.where(np.isfinite(cov), cov, 0.0) @ a.T
        run = runs[len(z)]
        e = run.wv.nu2 - run.model(par.to_components(best.theta))
        z.append(e / np.sqrt(np.maximum(np.diag(resid_cov), 1e-30 * np.diag(v))))
    dof = sum(r.wv.m.size for r in runs) - int(keep.sum())
    p_value = float(chi2.sf(best.objective, dof)) if dof > 0 else math.nan
    return Inference(cov, bool(ok and keep.all()), best.objective, dof, p_value, optimism, tuple(z))


def profile_interval(problem: Problem, best: Minimum, k: int, *, lower: bool = True, first_step: float = 0.25,
                     max_span: float = 40.0) -> tuple[float, float]:
    """95 % profile interval of log-parameter k: where the objective, minimised over the others, rises by
    :data:`CHI2_95`; bracketed in doubling steps from ``first_step``, bisected; ∓inf beyond ``max_span`` e-folds."""
    ends = []
    for direction in (-1.0, 1.0):
        if direction < 0 and not lower:
            ends.append(-math.inf)
            continue
        inside, outside, step = best.theta[k], None, first_step
        while step <= max_span:
            v = best.theta[k] + direction * step
            if problem.profile(best, k, v) > CHI2_95:
                outside = v
                break
            inside, step = v, 2.0 * step
        if outside is None:
            ends.append(direction * math.inf)
            continue
        while abs(outside - inside) > 0.01:
            mid = 0.5 * (inside + outside)
            inside, outside = (inside, mid) if problem.profile(best, k, mid) > CHI2_95 else (mid, outside)
        ends.append(0.5 * (inside + outside))
    return ends[0], ends[1]


def near_zero(problem: Problem, best: Minimum, k: int) -> bool:
    """Whether amplitude k shrunk a thousandfold raises the profiled objective by less than :data:`CHI2_95`."""
    if problem.par.entries[k][1] not in AMPLITUDES:
        return False
    value = best.theta[k] - math.log(1e3)
    lo = problem.box[0].copy()
    lo[k] = min(lo[k], value - 1.0)
    return problem.profile(best, k, value, (lo, problem.box[1])) < CHI2_95
