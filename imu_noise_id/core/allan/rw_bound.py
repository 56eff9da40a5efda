"""The largest random walk K [u/s/√Hz] a record's long-τ AV supports, as a simultaneous upper bound. AV(τ) ≥ K²τ/3
for any model with a random walk K; with AV_hat·ν/AV ~ χ²_ν (NIST SP1065 eq. 45, ν a random walk's EDF), U(τ) =
AV_hat(τ)·ν/χ²_ν(q), q = (1 − level)/M over the M estimates at τ ≥ τ_min (Bonferroni): K ≤ min_τ √(3·U(τ)/τ) jointly
with probability ≥ ``level``; a K's p-value min(1, M·min_τ F_ν(ν·AV_hat/(K²τ/3))). Why: docs/analysis.md."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from ..constants import CONFIDENCE_95
from ..noise.units import random_walk_at_allan_variance
from .edf import edf_of
from .estimators import AllanResult

#: Default shortest τ the bound reads, as a fraction of the record length.
RECORD_FRACTION = 0.1


@dataclass(frozen=True)
class RandomWalkBound:
    """The bound ``value`` [u/s/√Hz] (nan without estimates) at simultaneous ``level``, read over ``tau_range``
    (first, last) [s], attained at ``tau_at_minimum`` [s], from the AV estimates ``tau`` [s], ``variance`` [u²],
    ``edf``."""

    value: float
    level: float
    tau_range: tuple[float, float]
    tau_at_minimum: float
    tau: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    variance: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    edf: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)

    @property
    def estimates(self) -> int:
        """How many AV estimates the bound is simultaneous over (M)."""
        return int(self.tau.size)

    def p_value(self, random_walk: float) -> float:
        """Bonferroni p-value of AV(τ) ≥ K²τ/3 for K = ``random_walk`` [u/s/√Hz]; 1 without estimates."""
        if self.estimates == 0 or random_walk <= 0:
            return 1.0
        tails = stats.chi2.cdf(self.edf * self.variance / (random_walk**2 * self.tau / 3.0), self.edf)
        return float(min(1.0, self.estimates * float(np.min(tails))))

    def exceeded_by(self, random_walk: float | None) -> bool:
        """Whether a fitted K is above the bound (False for no K or no bound)."""
        return random_walk is not None and math.isfinite(self.value) and random_walk > self.value

    def excess(self, random_walk: float) -> str:
        """What a K above the bound means, in words."""
        return (f"above what the data's AV at τ = {self.tau_range[0]:.3g}–{self.tau_range[1]:.3g} s supports "
                f"({self.value:.3g} at {100 * self.level:.0f} %, p = {self.p_value(random_walk):.2g} over "
                f"{self.estimates} estimates): a bounded wander fits this record as well")


def random_walk_bound(res: AllanResult, axis: int = 0, *, tau_min: float | None = None,
                      level: float = CONFIDENCE_95) -> RandomWalkBound:
    """The ``level`` bound from column ``axis`` at τ ≥ ``tau_min`` [s] (default :data:`RECORD_FRACTION` of the
    record)."""
    if res.kind != "allan":
        raise ValueError(f"random_walk_bound: the Allan variance is needed, got {res.kind!r}")
    start = RECORD_FRACTION * res.n * res.dt if tau_min is None else float(tau_min)
    use = np.flatnonzero((res.tau >= start) & (res.variance[:, axis] >= 0))
    if use.size == 0:
        return RandomWalkBound(math.nan, level, (start, start), math.nan)
    tau = res.tau[use]
    edf = np.array([edf_of("allan", -2, int(m), res.n) for m in res.m[use]])
    upper = res.variance[use, axis] * edf / stats.chi2.ppf((1.0 - level) / use.size, edf)
    bounds = random_walk_at_allan_variance(upper, tau)
    i = int(np.argmin(bounds))
    return RandomWalkBound(float(bounds[i]), level, (float(tau[0]), float(tau[-1])), float(tau[i]), tau,
                           res.variance[use, axis].copy(), edf)
