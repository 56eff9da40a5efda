"""The largest random walk a record's long-τ Allan variance supports: a simultaneous upper confidence bound.

A fitted model's random walk K is judged by the likelihood and, in the closed loop, by the AV up to a tenth of the
record. Beyond that the AV estimates have few degrees of freedom each, yet they are what tells a random walk from a
bounded wander: on the first 1000 s of an ADIS16405 accelerometer (run 4 accel_z) the AV rises as K²τ/3 with
K ≈ 1.2·10⁻³ m/s²/√s from 17 s to 133 s, and the two halves of the record have the same mean to 1.5·10⁻⁴ m/s² (a
random walk of that K makes them differ by 2.4·10⁻² in sd): the record's own long-τ AV argues against the K the
model keeps (``bench/loop_measured.py``).

Since the AVs of independent components add, AV(τ) ≥ K²τ/3 at every τ for any model holding a random walk K. With
AV_hat(τ)·ν/AV(τ) read as χ²_ν (NIST SP1065 eq. 45; ν the EDF of a random walk, the smallest of the power laws
α ≥ −2, so the bound errs wide), the one-sided limit at level 1 − q,

    U(τ) = AV_hat(τ)·ν / χ²_ν(q),

lies below AV(τ) with probability q. Taking q = (1 − level)/M over the M estimates at τ ≥ τ_min (Bonferroni, valid
whatever their correlation), K ≤ min_τ √(3·U(τ)/τ) holds with probability ≥ ``level`` jointly. The minimum of
pointwise limits (q = 1 − level at each τ) does not: a true K exceeds it with probability up to M·(1 − level).
How strongly the data argue against a given K is the Bonferroni p-value min(1, M·min_τ F_ν(ν·AV_hat(τ)/(K²τ/3))),
F_ν the χ²_ν distribution function: one estimate of one degree of freedom at τ = N/2 (the two halves' means)
can bound K alone, and a near-zero one is not rare (P(χ²_1 < 10⁻⁴) ≈ 0.8 %), so a flag reports that p.
Beyond the papers (IEEE Std 952 reads K off the +½ slope and gives no bound for a record too short to show it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from ..noise.units import random_walk_at_allan_variance
from .edf import edf_of
from .estimators import AllanResult

#: The bound's default confidence level.
LEVEL = 0.95
#: By default the bound reads the AV from a tenth of the record on (where the loop's AV stops judging a model).
RECORD_FRACTION = 0.1


@dataclass(frozen=True)
class RandomWalkBound:
    """The largest random-walk density K [u/s/√Hz] the long-τ AV supports (module docstring).

    Attributes
    ----------
    value : the bound [u/s/√Hz]; nan when the record has no AV estimate at τ ≥ ``tau_range[0]``
    level : its confidence level, simultaneous over the :attr:`estimates` AV estimates it is the minimum over
    tau_range : the τ [s] read (first, last)
    tau_at_minimum : the τ [s] where the bound is attained
    tau, variance, edf : the AV estimates read: τ [s], AV [u²] and a random walk's EDF
    """

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
        """How strongly these AV estimates argue against a random walk K [u/s/√Hz]: the Bonferroni p-value of
        the hypothesis AV(τ) ≥ K²τ/3 (module docstring); 1 with no estimates."""
        if self.estimates == 0 or random_walk <= 0:
            return 1.0
        tails = stats.chi2.cdf(self.edf * self.variance / (random_walk**2 * self.tau / 3.0), self.edf)
        return float(min(1.0, self.estimates * float(np.min(tails))))

    def exceeded_by(self, random_walk: float | None) -> bool:
        """Whether a fitted K is above the bound (False for no K or no bound)."""
        return random_walk is not None and math.isfinite(self.value) and random_walk > self.value

    def excess(self, random_walk: float) -> str:
        """What a K above the bound means, in words (the bound, its τ, the p-value): for a value's source and a
        warning alike."""
        return (f"above what the data's AV at τ = {self.tau_range[0]:.3g}–{self.tau_range[1]:.3g} s supports "
                f"({self.value:.3g} at {100 * self.level:.0f} %, p = {self.p_value(random_walk):.2g} over "
                f"{self.estimates} estimates): a bounded wander fits this record as well")


def random_walk_bound(res: AllanResult, axis: int = 0, *, tau_min: float | None = None,
                      level: float = LEVEL) -> RandomWalkBound:
    """The simultaneous ``level`` upper bound on K from column ``axis`` of an Allan-variance result at
    τ ≥ ``tau_min`` [s] (default :data:`RECORD_FRACTION` of the record), module docstring."""
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
