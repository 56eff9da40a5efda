"""The noise-level CUSUMs on τ-cluster means (pair differences of variance 2·AV(τ), IEEE Std 952) against
2·AV_model(τ) of the reference within ±:data:`AV_TOLERANCE` (deviation), from :data:`MIN_PAIRS` pairs
(docs/analysis.md)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .noise_level import NoiseLevel, watch_noise_level
from .sequential import AxisWatch, SequentialNoiseWatch

if TYPE_CHECKING:
    from .axis_reference import AxisReference

#: Cluster times [s] the Allan variance is watched at (those with ≥ :data:`MIN_PAIRS` pairs in the data).
DEFAULT_TAUS = (1.0, 10.0)
#: Relative half-width, in Allan deviation, taken for the reference's AV at τ.
AV_TOLERANCE = 0.10
#: Fewest pairs of clusters a test runs on, and (online) the pairs after an alarm its confirmation rests on.
MIN_PAIRS = 50


def reference_av(reference: AxisReference, tau: float, dt: float) -> tuple[float, tuple[float, float]]:
    """2·AV(τ) [u²] of the reference's model at ``dt`` [s] and its ±:data:`AV_TOLERANCE` (deviation) interval."""
    v = reference.pair_variance(tau, dt)
    return v, (v * (1.0 - AV_TOLERANCE) ** 2, v * (1.0 + AV_TOLERANCE) ** 2)


def cluster_means(y: np.ndarray, m: int) -> np.ndarray:
    """Means of consecutive clusters of ``m`` samples of ``y`` (the last partial one dropped)."""
    k = y.size // m
    return np.asarray(y[: k * m], dtype=float).reshape(k, m).mean(axis=1)


def watch_allan(y: np.ndarray, dt: float, reference: AxisReference, tau: float, *, ratio: float,
                false_alarms_per_hour: float) -> NoiseLevel | None:
    """:func:`.noise_level.watch_noise_level` on the τ-cluster means against 2·AV(τ); None below :data:`MIN_PAIRS`
    pairs."""
    m = max(1, round(tau / dt))
    means = cluster_means(y, m)
    if means.size < 2 * MIN_PAIRS:
        return None
    v, interval = reference_av(reference, m * dt, dt)
    return watch_noise_level(means, m * dt, v, interval, ratio=ratio, false_alarms_per_hour=false_alarms_per_hour,
                             min_pairs=MIN_PAIRS)


class AllanWatch:
    """Online: a :class:`~.sequential.SequentialNoiseWatch` per τ of the τ-cluster means at ``period`` [s]."""

    def __init__(self, references: list[AxisReference], period: float, *, ratio: float,
                 false_alarms_per_hour: float, taus: tuple[float, ...] = DEFAULT_TAUS) -> None:
        self.sizes = [max(1, round(tau / period)) for tau in taus]
        self.taus = [m * period for m in self.sizes]
        self.watches = []
        for tau in self.taus:
            refs = [reference_av(r, tau, period) for r in references]
            self.watches.append(SequentialNoiseWatch([v for v, _ in refs], [i for _, i in refs], tau, ratio=ratio,
                                                     false_alarms_per_hour=false_alarms_per_hour,
                                                     window_s=max(60.0, 10 * tau), confirm_pairs=MIN_PAIRS))
        k = len(references)
        self.sums = np.zeros((len(taus), k))
        self.counts = [0] * len(taus)

    def add(self, t: float, sample: np.ndarray) -> None:
        """A stationary sample at stamp ``t`` [s]."""
        for j, m in enumerate(self.sizes):
            self.sums[j] += sample
            self.counts[j] += 1
            if self.counts[j] == m:
                self.watches[j].add(t, self.sums[j] / m)
                self.sums[j] = 0.0
                self.counts[j] = 0

    def break_chain(self) -> None:
        """Motion or a gap: the clusters and the pairs start again."""
        self.sums[:] = 0.0
        self.counts = [0] * len(self.sizes)
        for watch in self.watches:
            watch.break_chain()

    def axis(self, i: int) -> dict[float, AxisWatch]:
        """Axis ``i``'s state per τ [s] (its ratios in Allan deviation)."""
        return {tau: watch.axis(i) for tau, watch in zip(self.taus, self.watches, strict=True)}

