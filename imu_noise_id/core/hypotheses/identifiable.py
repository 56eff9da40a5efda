"""Hypotheses the record cannot tell apart (beyond paper 002; reasons: docs/hypotheses.md): a GM whose τ exceeds
:data:`LONG_TAU_FRACTION` of the span seen with probability ≥ ½ is its RW twin (density σ√(2/τ)) there: τ is
reported as > its :data:`LOWER_QUANTILE` quantile, the decision uses the pair's merged probability (named RW)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .model import Hypothesis, HypothesisSet

#: A GM whose τ exceeds this fraction of the span of data seen (with probability ≥ ½) is a random walk over it.
LONG_TAU_FRACTION = 0.5
#: The lower bound reported for such a τ: this posterior quantile.
LOWER_QUANTILE = 0.05


@dataclass(frozen=True)
class LongMemory:
    """A GM hypothesis whose τ the record cannot resolve: ``hypothesis``, its RW ``twin`` (or None), ``tau_lower_bound``
    [s], ``record_s`` [s], ``probability_long`` (Pr τ > LONG_TAU_FRACTION·record_s)."""

    hypothesis: str
    twin: str | None
    tau_lower_bound: float
    record_s: float
    probability_long: float

    def text(self) -> str:
        """One line for consoles and logs."""
        twin = f"indistinguishable from {self.twin}" if self.twin else "a random walk"
        return (f"{self.hypothesis}: GM.tau not identifiable (> {self.tau_lower_bound:.3g} s) on {self.record_s:.0f} s "
                f"of data: over this record it is {twin}")


def _twin(hyp: Hypothesis, hset: HypothesisSet) -> str | None:
    want = sorted("RW" if c == "GM" else c for c in hyp.components)
    return next((h.name for h in hset.hypotheses if sorted(h.components) == want), None)


def _tau_marginal(hyp: Hypothesis, lj: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cell edges of τ and the posterior mass of each τ cell (from the hypothesis' log weights lj (M,))."""
    shape = tuple(p.n if not p.known else 1 for p in hyp.priors)
    d = hyp.parameter_names.index("GM.tau")
    w = np.exp(lj - lj.max()).reshape(shape)
    mass = w.sum(axis=tuple(i for i in range(len(shape)) if i != d))
    prior = hyp.priors[d]
    edges = prior.edges() if not prior.known else np.array([prior.low, prior.low])
    return edges, mass / mass.sum()


def _cdf_at(edges: np.ndarray, mass: np.ndarray, tau: float, log: bool) -> float:
    """Posterior probability of τ ≤ ``tau``, each cell's mass spread uniformly in τ (log τ on log grids)."""
    below = 0.0
    for lo, hi, m in zip(edges[:-1], edges[1:], mass, strict=True):
        if tau >= hi:
            below += m
        elif tau > lo:
            frac = math.log(tau / lo) / math.log(hi / lo) if log else (tau - lo) / (hi - lo)
            below += m * frac
    return below


def _quantile(edges: np.ndarray, mass: np.ndarray, q: float, log: bool) -> float:
    cdf = np.concatenate([[0.0], np.cumsum(mass)])
    i = int(np.clip(np.searchsorted(cdf, q) - 1, 0, mass.size - 1))
    frac = (q - cdf[i]) / mass[i] if mass[i] > 0 else 0.0
    lo, hi = edges[i], edges[i + 1]
    return float(lo * (hi / lo) ** frac if log else lo + frac * (hi - lo))


def long_memory(hset: HypothesisSet, log_weights: list[np.ndarray], record_s: float) -> list[LongMemory]:
    """The GM hypotheses whose τ ``record_s`` [s] cannot resolve; ``log_weights[k]``: log μ₀ + c (M_k,) of each."""
    out = []
    for hyp, lj in zip(hset.hypotheses, log_weights, strict=True):
        if "GM.tau" not in hyp.parameter_names or not record_s > 0:
            continue
        prior = hyp.priors[hyp.parameter_names.index("GM.tau")]
        edges, mass = _tau_marginal(hyp, lj)
        log = prior.spacing == "log"
        if prior.known:
            p_long = float(prior.low > LONG_TAU_FRACTION * record_s)
            bound = prior.low
        else:
            p_long = 1.0 - _cdf_at(edges, mass, LONG_TAU_FRACTION * record_s, log)
            bound = _quantile(edges, mass, LOWER_QUANTILE, log)
        if p_long >= 0.5:
            out.append(LongMemory(hyp.name, _twin(hyp, hset), float(bound), float(record_s), float(p_long)))
    return out


def merged_probabilities(probabilities: dict[str, float], groups: list[LongMemory]) -> dict[str, float]:
    """The probabilities with each long-memory GM hypothesis added to its RW twin (sums clipped to 1)."""
    merged = dict(probabilities)
    for g in groups:
        if g.twin is not None and g.hypothesis in merged and g.twin in merged:
            merged[g.twin] = min(1.0, merged[g.twin] + merged.pop(g.hypothesis))
    return merged
