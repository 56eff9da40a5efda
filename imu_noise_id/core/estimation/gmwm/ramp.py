"""The ramp of a GMWM fit (beyond the papers): an RR's slope ω enters the Haar WV as (ω·τ/2)²; the record's
least-squares slope ω̂ has E ω̂ = ω, Var ω̂ = V(θ) (:func:`~imu_noise_id.core.noise.trend.ls_slope_variance`) and is
uncorrelated with the WV for Gaussian noise. GMWM eq. 3 plus one term, a the WV's ramp magnitude:

    J(θ, a, ω) = (ν̂ − ν(θ, a))ᵀ Ω (ν̂ − ν(θ, a)) + (ω̂ − ω)² / V(θ).                   (1)

The slope minimises J_p(v) = min_{θ,a} J(θ, a, v); its 95 % interval is {v : J_p(v) − min J_p ≤ χ²₁,₀.₉₅}."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq, least_squares, minimize_scalar

from ...noise.trend import ls_slope_variance
from ..readouts.quantiles import CHI2_95, Z95
from . import engine as eng

#: Bracketing steps outward from the centre (in units of the plug-in standard error √V(θ̂)) before giving up.
MAX_STEPS = 12


@dataclass(frozen=True)
class RampFit:
    """The slope [u/s] from eq. (1), its standard error (interval half-width / 1.96) and 95 % interval."""

    slope: float
    se: float
    ci95: tuple[float, float]


@dataclass
class _Profile:
    problem: eng.Problem
    ls_slope: float
    n: int
    dt: float
    start: np.ndarray

    def residuals(self, theta: np.ndarray, v: float) -> np.ndarray:
        try:
            var = ls_slope_variance(self.problem.par.to_components(theta), self.n, self.dt)
        except ValueError:
            var = math.nan
        slope_term = (self.ls_slope - v) / math.sqrt(var) if var > 0 else 1e8
        return np.append(self.problem.residuals(theta), slope_term)

    def jacobian(self, theta: np.ndarray, v: float) -> np.ndarray:
        """∂/∂θᵀ of :meth:`residuals`: the WV rows of :meth:`.engine.Problem.residual_jacobian` and the slope
        term's −(ω̂ − v)/(2V^{3/2})·∂V/∂θ (:func:`.engine.log_gradient`)."""
        row = np.zeros(theta.size)
        try:
            var = ls_slope_variance(self.problem.par.to_components(theta), self.n, self.dt)
            if var > 0:
                grad = eng.log_gradient(self.problem.par, theta, lambda c: ls_slope_variance([c], self.n, self.dt))
                row = -0.5 * (self.ls_slope - v) / var**1.5 * grad
        except ValueError:
            pass
        return np.vstack([self.problem.residual_jacobian(theta), row])

    def __call__(self, v: float) -> float:
        """J_p(v): eq. (1) minimised over the noise parameters and the WV's ramp term with the slope at v."""
        lo, hi = self.problem.box
        x0 = np.clip(self.start, lo + 1e-9, hi - 1e-9)
        sol = least_squares(lambda th: self.residuals(th, v), x0, jac=lambda th: self.jacobian(th, v), bounds=(lo, hi),
                            method="trf", x_scale="jac", xtol=1e-6, ftol=1e-6, gtol=1e-6,
                            max_nfev=50 * (self.start.size + 1))
        self.start = sol.x
        return 2.0 * float(sol.cost)


def fit_ramp(problem: eng.Problem, theta: np.ndarray, ls_slope: float, n: int, dt: float) -> RampFit:
    """RR slope at the WV fit ``theta`` by eq. (1), ``ls_slope`` [u/s] from ``n`` samples at ``dt`` [s]."""
    prof = _Profile(problem, ls_slope, n, dt, theta.copy())
    sd = math.sqrt(ls_slope_variance(problem.par.to_components(theta), n, dt))
    best = minimize_scalar(prof, bounds=(ls_slope - 4.0 * sd, ls_slope + 4.0 * sd), method="bounded",
                           options={"xatol": 0.02 * sd})
    centre, floor, at_centre = float(best.x), float(best.fun), prof.start.copy()
    ends = []
    for direction in (-1.0, 1.0):
        prof.start = at_centre.copy()
        inside, outside = centre, None
        for step in range(1, MAX_STEPS + 1):
            v = centre + direction * sd * 2.0 ** (step - 1)
            if prof(v) - floor > CHI2_95:
                outside = v
                break
            inside = v
        if outside is None:
            ends.append(direction * math.inf)
            continue
        ends.append(brentq(lambda v: prof(v) - floor - CHI2_95, inside, outside, xtol=0.01 * sd))
    lo, hi = ends
    return RampFit(centre, (hi - lo) / (2.0 * Z95), (lo, hi))
