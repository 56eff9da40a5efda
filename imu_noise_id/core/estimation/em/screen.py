"""Whether a candidate structure is worth its exact fit, from its likelihood gain on two statistics of fixed size
(beyond the papers): the banded Whittle likelihood (:mod:`.whittle`) and the block sums' exact likelihood
(:mod:`.block_sums`). The gain is the larger of the two over a few starts (:func:`_starts`, and the structure's
further starts); the candidate goes on when −2·gain + Δk·ln N < :data:`MARGIN` (docs/em.md, "Screening on statistics
of fixed size"). Each statistic's maximum is kept (:class:`Maximum`): a reading of the structure in its own right."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ...noise.components import GM, Component
from ...noise.modelspec import nests
from . import block_sums, mle, whittle

#: Screen ΔBIC below which a candidate is fitted exactly (units of −2 ln L).
MARGIN = 10.0
#: Shortest GM τ [samples] a screen starts from.
SHORTEST_TAU_SAMPLES = 5.0
#: Fewest samples for which screening pays (below, an exact refit takes a few seconds).
MIN_SAMPLES = 250_000


@dataclass(frozen=True)
class Statistics:
    """The record's two screening statistics (computed once per record) and its length."""

    periodogram: whittle.BandedPeriodogram
    sums: block_sums.BlockSums
    dt: float
    n: int

    @classmethod
    def of(cls, y: np.ndarray, dt: float) -> Statistics:
        """Both statistics of one axis ``y`` [u] (gap-filled) at period ``dt`` [s]."""
        return cls(whittle.banded_periodogram(y), block_sums.block_sums(y, dt), float(dt), int(y.size))

    def whittle_fit(self, start: list[Component]) -> tuple[float, list[Component]]:
        """(banded Whittle log-likelihood, components) maximised from ``start`` (the estimator's physical bounds), to
        the maximum: a screen's gain is a difference of two such values."""
        bounds = mle.physical_bounds(self.n, self.dt)
        return whittle.whittle_fit(start, np.empty(0), self.dt, self.periodogram, bounds, to_maximum=True)


@dataclass(frozen=True)
class Reference:
    """The current structure fitted to both statistics (shared by every candidate screened against it): its
    (exactly fitted) ``components``, and per statistic the maximised log-likelihood and the components there."""

    components: list[Component]
    whittle_loglik: float
    block_loglik: float
    whittle_components: tuple[Component, ...]
    block_components: tuple[Component, ...]

    @classmethod
    def fit(cls, components: list[Component], stats: Statistics) -> Reference:
        whittle_loglik, at_whittle = stats.whittle_fit(components)
        block_loglik, at_blocks = block_sums.fit(components, stats.sums)
        return cls(list(components), whittle_loglik, block_loglik, tuple(at_whittle), tuple(at_blocks))


@dataclass(frozen=True)
class Maximum:
    """A candidate's maximum on one statistic (``"whittle"``/``"block sums"``): its log-likelihood ``gain`` over the
    current structure there, the ``components`` there and the current structure's components fitted on that statistic
    (``reference_components``: what the statistic reads where the exact fit reads the current structure's own; a
    parameter the statistic reads poorly, e.g. K on the banded periodogram, is read off the candidate relative to
    it)."""

    statistic: str
    gain: float
    components: tuple[Component, ...]
    reference_components: tuple[Component, ...]


@dataclass(frozen=True)
class Screen:
    """A candidate's ``maxima`` on the statistics (one per statistic fitted, the largest gain first), its
    ``extra_parameters`` (negative: fewer) over the current structure, ``penalty`` ln N and whether it ``nests`` the
    current structure (then never credited with a loss). The verdict reads the best maximum; each maximum is also a
    reading of the structure in its own right: the two statistics see different frequencies (the banded periodogram
    the short τ, the block sums the long τ) and may each find a different mode of the same structure."""

    maxima: tuple[Maximum, ...]
    extra_parameters: int
    penalty: float
    nests: bool = False

    def credited(self, maximum: Maximum) -> float:
        """The log-likelihood gain ``maximum`` credits the candidate with (not below 0 when it :attr:`nests`)."""
        return max(maximum.gain, 0.0) if self.nests else maximum.gain

    @property
    def gain(self) -> float:
        """The best maximum's :meth:`credited` gain."""
        return self.credited(self.maxima[0])

    @property
    def statistic(self) -> str:
        """The statistic of the best maximum."""
        return self.maxima[0].statistic

    @property
    def components(self) -> tuple[Component, ...]:
        """The components at the best maximum."""
        return self.maxima[0].components

    def delta_bic_at(self, maximum: Maximum) -> float:
        """The BIC change ``maximum`` says the candidate could reach."""
        return -2.0 * self.credited(maximum) + self.extra_parameters * self.penalty

    def delta_aic_at(self, maximum: Maximum) -> float:
        """The AIC change ``maximum`` says the candidate could reach."""
        return -2.0 * self.credited(maximum) + 2.0 * self.extra_parameters

    @property
    def delta_bic(self) -> float:
        """The BIC change the statistics say the candidate could reach."""
        return self.delta_bic_at(self.maxima[0])

    @property
    def delta_aic(self) -> float:
        """The AIC change the statistics say the candidate could reach."""
        return self.delta_aic_at(self.maxima[0])

    @property
    def worth_exact_fit(self) -> bool:
        return self.delta_bic < MARGIN

    def describe(self) -> str:
        return (f"screened on statistics of fixed size: best log-likelihood gain {self.gain:.1f} ({self.statistic}) "
                f"for {self.extra_parameters:+d} parameters, ΔBIC ≥ {self.delta_bic:+.1f} (exact fit from "
                f"{MARGIN:g})")


def _n_parameters(components: list[Component]) -> int:
    return sum(len(c.parameter_names) for c in components)


def _restored(candidate: list[Component], current: list[Component]) -> list[Component]:
    """``candidate`` with each component the current structure has of its type (in order) at its current value."""
    pool = {name: [c for c in current if c.name == name] for name in {c.name for c in current}}
    return [pool[c.name].pop(0) if pool.get(c.name) else c for c in candidate]


def _starts(candidate: list[Component], current: list[Component], dt: float) -> list[list[Component]]:
    """The candidate's start and its :func:`_restored` version, each also with its added GMs' τ a decade shorter at a
    time down to :data:`SHORTEST_TAU_SAMPLES` samples."""
    known = set(current)
    bases = [candidate] + ([restored] if (restored := _restored(candidate, current)) != candidate else [])
    out = []
    for base in bases:
        scale = 1.0
        while True:
            moved = [replace(c, tau=c.tau * scale) if isinstance(c, GM) and c not in known else c for c in base]
            added = [c for c in moved if isinstance(c, GM) and c not in known]
            if scale < 1.0 and (not added or all(c.tau < SHORTEST_TAU_SAMPLES * dt for c in added)):
                break
            out.append(moved)
            scale *= 0.1
    return out


def screen(reference: Reference, candidate: list[Component], stats: Statistics,
           others: Sequence[list[Component]] = ()) -> Screen:
    """The statistics' verdict on ``candidate`` (starting components, and :func:`_starts` around them) and on the
    same structure's ``others`` starts (each as given: e.g. the exact fit's further AV-fit starts, whose modes the
    first start's shorter GMs do not reach) against ``reference``: each statistic's maximum over the starts."""
    block_span = stats.sums.block * stats.dt
    known = set(reference.components)
    best: dict[str, tuple[float, list[Component]]] = {}
    for start in [*_starts(candidate, reference.components, stats.dt), *map(list, others)]:
        fits = [("whittle", *stats.whittle_fit(start))]
        if all(c.tau >= block_span for c in start if isinstance(c, GM) and c not in known):
            fits.append(("block sums", *block_sums.fit(start, stats.sums)))
        for statistic, loglik, fitted in fits:
            gain = loglik - (reference.whittle_loglik if statistic == "whittle" else reference.block_loglik)
            if statistic not in best or gain > best[statistic][0]:
                best[statistic] = (gain, fitted)
    at_reference = {"whittle": reference.whittle_components, "block sums": reference.block_components}
    maxima = sorted((Maximum(statistic, gain, tuple(fitted), at_reference[statistic])
                     for statistic, (gain, fitted) in best.items()), key=lambda m: -m.gain)
    return Screen(tuple(maxima), _n_parameters(candidate) - _n_parameters(reference.components), math.log(stats.n),
                  nests(candidate, reference.components))
