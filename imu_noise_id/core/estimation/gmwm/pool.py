"""Pooled GMWM over several records of one sensor with a test that they share one model (MGMWM; Bakalli, Guerrier et
al., "Multi-signal approaches for repeated sampling schemes in inertial sensor calibration"): θ̂ = argmin Σ_k
(ν̂_k − ν_k(θ))ᵀ Ω_k (ν̂_k − ν_k(θ)). Compatibility at the 5 % level (beyond the paper, after Hansen's J-test), Ω_k held
fixed:

    C = J_pooled(θ̂) − Σ_k J_k(θ̂_k) = Σ_k [J_k(θ̂) − J_k(θ̂_k)] ~ χ²((K − 1)·p)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from ...errors import InputError
from ...kalman import statespace as ss
from ...noise.components import Component
from ...wavelet.variance import WaveletVariance
from ..em.model import parse_structure_or_components
from . import engine as eng
from .fit import GmwmFit, GmwmOptions, dress, estimate, fit_gmwm, prepare, starting_values

#: Level of the compatibility test.
COMPATIBILITY_ALPHA = 0.05


@dataclass
class PooledFit:
    """One structure fitted to K records.

    Attributes
    ----------
    fit : the pooled fit (one θ; ``n`` total samples; ``wv``/``residual_z`` of the first record)
    runs : each record's own fit
    j_statistic, dof, p_value : the pooled J-test, χ²(Σ J_k − p)
    compatibility, compatibility_dof, compatibility_p : C, (K − 1)·p and its p-value
    residual_z, run_rise : per record, the pooled fit's standardised WV residuals and J_k(θ̂) − J_k(θ̂_k)
    """

    fit: GmwmFit
    runs: list[GmwmFit]
    j_statistic: float
    dof: int
    p_value: float
    compatibility: float
    compatibility_dof: int
    compatibility_p: float
    residual_z: list[np.ndarray]
    run_rise: list[float]

    @property
    def compatible(self) -> bool:
        return self.compatibility_p >= COMPATIBILITY_ALPHA


def fit_pooled(records: list[tuple[np.ndarray, float]] | list[WaveletVariance], structure: str | list[Component], *,
               options: GmwmOptions | None = None) -> PooledFit:
    """Pooled fit of ``structure`` to ``records`` ((samples, dt) pairs or WVs) and the compatibility test; InputError
    with fewer than two records or a bad record or structure."""
    options = options or GmwmOptions()
    if len(records) < 2:
        raise InputError(f"pooling needs at least two records of the sensor, got {len(records)}")
    names, given = parse_structure_or_components(structure)
    ss.validate_structure(names)
    wvs = [r if isinstance(r, WaveletVariance) else prepare(r[0], r[1], options)[0] for r in records]
    runs = [eng.Moments(wv) for wv in wvs]
    own = [fit_gmwm(None, wv.dt, structure, options=options, wv=wv) for wv in wvs]
    starts = [list(given)] if given else [s for wv in wvs for s in starting_values(names, wv, 1)]
    est = estimate(runs, starts + [list(f.components) for f in own])
    pooled = dress(est, n=sum(wv.n for wv in wvs), dt=wvs[0].dt, options=options)
    # Each record's own minimum under the pooled fit's weight (the same Ω_k as in J_pooled); C = Σ_k of the rises.
    rise = []
    for k, run in enumerate(runs):
        problem = eng.Problem(est.problem.par, [run], eng.Weights((est.problem.weights.whiten[k],),
                                                                  (est.problem.weights.covariance[k],)),
                              est.problem.box)
        own_min = min(problem.minimise(est.best.theta).objective,
                      problem.minimise(est.problem.par.to_theta(own[k].components)).objective)
        rise.append(max(problem.objective(est.best.theta) - own_min, 0.0))
    c_stat = float(sum(rise))
    c_dof = (len(runs) - 1) * est.best.theta.size
    return PooledFit(pooled, own, est.inference.j_statistic, est.inference.dof, est.inference.p_value, c_stat, c_dof,
                     float(chi2.sf(c_stat, c_dof)) if c_dof > 0 else math.nan, list(est.inference.residual_z), rise)
