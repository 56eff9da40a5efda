"""The largest random walk K [u/s/√Hz] a record's long-τ AV supports, as a simultaneous upper bound. AV(τ) ≥ K²τ/3
for any model with a random walk K; with AV_hat·ν/AV ~ χ²_ν (NIST SP1065 eq. 45, ν a random walk's EDF), U(τ) =
AV_hat(τ)·ν/χ²_ν(q), q = (1 − level)/M_eff over the M estimates at τ ≥ τ_min: K ≤ min_τ √(3·U(τ)/τ) jointly with
probability ``level``; a K's p-value min(1, M_eff·min_τ F_ν(ν·AV_hat/(K²τ/3))).

M_eff (:func:`independent_estimates`, 1 ≤ M_eff ≤ M) is the number of independent estimates the M are worth: the
long-τ estimates of one record overlap and are strongly correlated, so Bonferroni over all M (M_eff = M) holds the
bound at about 99 % where 95 % is claimed. M_eff is calibrated on simulated records of a random walk alone, the least
favourable case (every other independent noise adds AV at every τ): q is the (1 − level) quantile of
min_τ F_ν(ν·AV_hat/AV) over them. Beyond NIST SP1065 (which bounds one τ at a time). Why: docs/analysis.md."""

from __future__ import annotations

import functools
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
#: Simulated records of a random walk alone :func:`independent_estimates` is calibrated on (the level's quantile of
#: their minimum lies ~200 records deep at 95 %: about ±7 % in M_eff).
CALIBRATION_RECORDS = 4000
#: Simulated records per batch (bounds the calibration's memory to a few tens of MB).
CALIBRATION_BATCH = 250
#: Steps of a calibration record per shortest averaging time, and at most per record: coarser than the record's own
#: rate, where the overlapping estimators' spread has nearly settled (checked end to end at the records' own rate by
#: bench/bench_rw_bound.py: a true walk below the bound in 3.6-5.0 % of records alone).
CALIBRATION_STEPS_PER_TAU = 32
CALIBRATION_MAX_STEPS = 4096
#: The calibration's seed: M_eff is a deterministic function of the estimates' averaging factors and record length.
CALIBRATION_SEED = 952


@dataclass(frozen=True)
class RandomWalkBound:
    """The bound ``value`` [u/s/√Hz] (nan without estimates) at simultaneous ``level``, read over ``tau_range``
    (first, last) [s], attained at ``tau_at_minimum`` [s], from the AV estimates ``tau`` [s], ``variance`` [u²],
    ``edf``, worth ``independent`` independent estimates (M_eff, :func:`independent_estimates`)."""

    value: float
    level: float
    tau_range: tuple[float, float]
    tau_at_minimum: float
    tau: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    variance: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    edf: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    independent: float = 1.0

    @property
    def estimates(self) -> int:
        """How many AV estimates the bound is simultaneous over (M)."""
        return int(self.tau.size)

    def p_value(self, random_walk: float) -> float:
        """p-value of AV(τ) ≥ K²τ/3 for K = ``random_walk`` [u/s/√Hz], Bonferroni over the M_eff independent
        estimates the M are worth (:attr:`independent`); 1 without estimates."""
        if self.estimates == 0 or random_walk <= 0:
            return 1.0
        tails = stats.chi2.cdf(self.edf * self.variance / (random_walk**2 * self.tau / 3.0), self.edf)
        return float(min(1.0, self.independent * float(np.min(tails))))

    def exceeded_by(self, random_walk: float | None) -> bool:
        """Whether a fitted K is above the bound (False for no K or no bound)."""
        return random_walk is not None and math.isfinite(self.value) and random_walk > self.value

    def excess(self, random_walk: float) -> str:
        """What a K above the bound means, in words."""
        return (f"above what the data's AV at τ = {self.tau_range[0]:.3g}–{self.tau_range[1]:.3g} s supports "
                f"({self.value:.3g} at {100 * self.level:.0f} %, p = {self.p_value(random_walk):.2g} over "
                f"{self.estimates} estimates, {self.worth()}): a bounded wander fits this record as well")

    def worth(self) -> str:
        """``as many as 2.1 independent ones``: what the estimates are worth, in words."""
        return f"as many as {self.independent:.2g} independent ones"


def random_walk_bound(res: AllanResult, axis: int = 0, *, tau_min: float | None = None,
                      level: float = CONFIDENCE_95) -> RandomWalkBound:
    """The ``level`` bound from column ``axis`` at τ ≥ ``tau_min`` [s] (default :data:`RECORD_FRACTION` of the
    record), simultaneous over its estimates by :func:`independent_estimates`."""
    if res.kind != "allan":
        raise ValueError(f"random_walk_bound: the Allan variance is needed, got {res.kind!r}")
    start = RECORD_FRACTION * res.n * res.dt if tau_min is None else float(tau_min)
    use = np.flatnonzero((res.tau >= start) & (res.variance[:, axis] >= 0))
    if use.size == 0:
        return RandomWalkBound(math.nan, level, (start, start), math.nan)
    tau = res.tau[use]
    factors = tuple(int(m) for m in res.m[use])
    edf = walk_edf(factors, int(res.n))
    independent = independent_estimates(factors, int(res.n), level)
    upper = res.variance[use, axis] * edf / stats.chi2.ppf((1.0 - level) / independent, edf)
    bounds = random_walk_at_allan_variance(upper, tau)
    i = int(np.argmin(bounds))
    return RandomWalkBound(float(bounds[i]), level, (float(tau[0]), float(tau[-1])), float(tau[i]), tau,
                           res.variance[use, axis].copy(), edf, independent)


def walk_edf(factors: tuple[int, ...], n: int) -> np.ndarray:
    """ν_j: a random walk's EDF (:func:`~.edf.edf_of`, α = −2) of the overlapping AV at each averaging factor of
    ``factors`` over ``n`` samples, the ν both the bound and its calibration read each estimate with."""
    return np.array([edf_of("allan", -2, int(m), n) for m in factors])


@functools.lru_cache(maxsize=64)
def independent_estimates(factors: tuple[int, ...], n: int, level: float = CONFIDENCE_95) -> float:
    """M_eff ∈ [1, M]: the number of independent estimates the overlapping Allan variances of a record of ``n``
    samples at the averaging factors ``factors`` (M of them) are worth for a bound at ``level``: (1 − level)/q, q the
    (1 − level) quantile of min_j F_νj(ν_j·AV_hat_j/AV_j) over :data:`CALIBRATION_RECORDS` simulated records of a
    random walk alone (ν_j the walk's EDF, :func:`walk_edf`). The records are simulated at a coarser step (a
    discrete walk of unit steps, AV_j = (2k² + 1)/(6k) at k steps), :data:`CALIBRATION_STEPS_PER_TAU` steps per the
    shortest averaging time, at most :data:`CALIBRATION_MAX_STEPS` per record; seeded (:data:`CALIBRATION_SEED`).
    Beyond NIST SP1065: module docstring."""
    m = np.asarray(factors, dtype=float)
    if m.size <= 1:
        return 1.0
    step = max(1.0, math.floor(m.min() / CALIBRATION_STEPS_PER_TAU), math.ceil(n / CALIBRATION_MAX_STEPS))
    length = int(n // step)
    k = np.clip(np.rint(m / step).astype(int), 1, max(1, (length - 1) // 2))
    edf = walk_edf(factors, n)
    expected = (2.0 * k**2 + 1.0) / (6.0 * k)
    rng = np.random.default_rng(CALIBRATION_SEED)
    minima = []
    for start in range(0, CALIBRATION_RECORDS, CALIBRATION_BATCH):
        batch = min(CALIBRATION_BATCH, CALIBRATION_RECORDS - start)
        walk = np.cumsum(rng.standard_normal((batch, length)), axis=1)
        phase = np.concatenate([np.zeros((batch, 1)), np.cumsum(walk, axis=1)], axis=1)
        tails = np.empty((batch, m.size))
        for j, kj in enumerate(k):
            second = phase[:, 2 * kj:] - 2.0 * phase[:, kj:-kj] + phase[:, : -2 * kj]
            av = np.mean(second * second, axis=1) / (2.0 * kj * kj)
            tails[:, j] = stats.chi2.cdf(edf[j] * av / expected[j], edf[j])
        minima.append(tails.min(axis=1))
    q = float(np.quantile(np.concatenate(minima), 1.0 - level))
    return float(np.clip((1.0 - level) / q, 1.0, m.size)) if q > 0.0 else float(m.size)
