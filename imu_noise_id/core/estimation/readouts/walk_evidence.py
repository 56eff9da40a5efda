"""The random walk K under model uncertainty: what the structures the data cannot tell apart say about K.

A selection's candidates are fitted to one record; those within Occam's window on either information criterion (a weight
at least :data:`OCCAM_RATIO` of the best's: ΔBIC or ΔAIC ≤ 2 ln 20, Madigan & Raftery 1994; Burnham & Anderson 2002,
§2.9) are the structures the data cannot tell apart. Each gives its reading of K over the record (:func:`record_walk`):
its RW's density, with every GM slower than the record taken as a walk (K² = 2σ²/τ: above its corner 1/(2πτ), where all
the record's frequencies lie, a GM's spectrum is a walk's), or 0 when it has neither (a GM that explains the long-τ AV
instead of a walk), with a 95 % Wald interval from Whittle's Fisher information of the record's length
(:func:`walk_interval`: no pass over the data). A walk or GM whose share of the model's spectrum is below
:data:`VISIBLE_SHARE` at every frequency of the record (a component the fit collapsed, e.g. a GM of τ 0.01 s and σ 3e-9
beside a white noise of 1e-3) enters no reading (:func:`visible_components`): its parameters have no information, and
the reading would depend on how the machine's rounding treats that null space. K's interval is the union (hull) of the
final model's interval and theirs (:func:`over_structures`); where it reaches zero (a structure within the evidence has
no walk) K is given as an upper bound U, method ``bound``, as a K whose own interval reaches zero is
(:func:`~.kalibr.unidentified_as_bound`): the largest of the structures' one-sided 95 % upper limits
(:func:`one_sided_upper`), so that [0, U] is the 95 % interval it is labelled, not a 97.5 % one. Why: docs/analysis.md,
"Why K's interval spans the structures the data cannot tell apart".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...errors import InputError
from ...noise.base import Component
from ...noise.components import GM, RW
from ..em import mle, whittle
from ..em.selection import SelectionResult
from ..em.uncertainty import WALD_MAX_SE_LOG
from .kalibr import KalibrValue
from .quantiles import Z95, Z95_ONE_SIDED

#: A structure is within the evidence when its BIC or AIC weight is at least this ratio of the best's.
OCCAM_RATIO = 1.0 / 20.0
#: The largest ΔBIC or ΔAIC within :data:`OCCAM_RATIO` (2 ln 20 ≈ 5.99).
OCCAM_DELTA = -2.0 * math.log(OCCAM_RATIO)
#: Largest standard error of ln K whose Wald interval is held determined: the fits' own rule
#: (:data:`~..em.uncertainty.WALD_MAX_SE_LOG`, an interval wider than ×7 each way), which replaces such an interval
#: by a profile; a reading has no pass over the data for one.
MAX_LOG_SE = WALD_MAX_SE_LOG
#: Largest share of the model's spectrum a walk or GM may hold at every frequency of a record and still be held
#: collapsed (:func:`visible_components`): Whittle's information of such a component is of order n·share², 10⁻² at
#: 10¹⁰ samples.
VISIBLE_SHARE = 1e-6
#: Log-spaced frequencies of the record's band on which a component's share is read (walks and GMs are smooth).
SHARE_GRID = 256


@dataclass(frozen=True)
class WalkReading:
    """One structure's reading of K: its name, ΔBIC and ΔAIC to the best, K over the record [u/s/√Hz] (0: no walk)
    and its 95 % interval (None where the information does not determine one)."""

    structure: str
    delta_bic: float
    delta_aic: float
    random_walk: float
    ci95: tuple[float, float] | None

    @property
    def span(self) -> tuple[float, float]:
        """The interval, or (K, K) where it is not determined."""
        return self.ci95 if self.ci95 is not None else (self.random_walk, self.random_walk)

    def describe(self) -> str:
        """``WN+GM (BIC +3.8, AIC +0.8 over the best): no walk over the record`` or ``… K 4.86e-05 [3.5e-05,
        6.8e-05]`` (plain ASCII: it is written into YAML)."""
        if self.random_walk == 0.0:
            k = "no walk over the record"
        elif self.ci95 is None:
            k = f"K {self.random_walk:.3g} (its interval not determined)"
        else:
            k = f"K {self.random_walk:.3g} [{self.ci95[0]:.3g}, {self.ci95[1]:.3g}]"
        return f"{self.structure} (BIC {self.delta_bic:+.1f}, AIC {self.delta_aic:+.1f} over the best): {k}"


def visible_components(components: list[Component], n: int, dt: float) -> list[Component]:
    """``components`` without each RW or GM whose share of the model's spectrum of differences
    (:func:`~..em.whittle.difference_spectrum`) stays below :data:`VISIBLE_SHARE` at every frequency of a record of
    ``n`` samples at ``dt`` [s] (:data:`SHARE_GRID` log-spaced from 2π/(n − 1) to π rad/sample)."""
    omega = np.geomspace(2.0 * math.pi / max(int(n) - 1, 2), math.pi, SHARE_GRID)
    parts = [whittle.difference_spectrum([c], omega, dt) for c in components]
    total = np.sum(parts, axis=0)
    if not np.all(total > 0.0):
        return list(components)
    return [c for c, part in zip(components, parts, strict=True)
            if not isinstance(c, RW | GM) or np.max(part / total) >= VISIBLE_SHARE]


def _structure(components: list[Component]) -> tuple[str, ...]:
    """The component types of ``components``, in order (``("WN", "RW")``)."""
    return tuple(type(c).__name__ for c in components)


def _walk_carriers(components: list[Component], span_s: float) -> list[tuple[int, RW | GM]]:
    """(index, component) of each component that is a walk over a record of ``span_s`` [s]: an RW, or a GM slower
    than the record."""
    return [(i, c) for i, c in enumerate(components)
            if isinstance(c, RW) or (isinstance(c, GM) and c.tau > span_s)]


def _walk_terms(components: list[Component], span_s: float) -> dict[tuple[int, str], float]:
    """Per log-parameter of ``components`` (component index, name), ∂(K²)/∂ln(parameter) of :func:`record_walk`."""
    terms: dict[tuple[int, str], float] = {}
    for i, c in _walk_carriers(components, span_s):
        if isinstance(c, RW):
            terms[(i, "random_walk")] = 2.0 * c.random_walk**2
        else:
            terms[(i, "sigma")] = 4.0 * c.sigma**2 / c.tau
            terms[(i, "tau")] = -2.0 * c.sigma**2 / c.tau
    return terms


def record_walk(components: list[Component], span_s: float) -> float:
    """K [u/s/√Hz] of ``components`` over a record of ``span_s`` [s]: √(K_RW² + Σ 2σ²/τ over GMs with τ > span)."""
    return math.sqrt(sum(c.random_walk**2 if isinstance(c, RW) else 2.0 * c.sigma**2 / c.tau
                         for _, c in _walk_carriers(components, span_s)))


def walk_interval(components: list[Component], n: int, dt: float) -> tuple[float, float] | None:
    """95 % Wald interval of :func:`record_walk` of the :func:`visible_components` over ``n`` samples at ``dt`` [s],
    on ln K, by the delta method from Whittle's Fisher information of ``n`` samples
    (:func:`~..em.whittle.fisher_information`); (0, 0) without a visible walk, None where the information leaves K
    undetermined (singular, or sd(ln K) above :data:`MAX_LOG_SE`: a slow GM beside a walk it outweighs reads K to no
    order of magnitude, e^(±1.96 sd) up to 10²⁷-fold)."""
    span = n * dt
    components = visible_components(components, n, dt)
    k = record_walk(components, span)
    if k == 0.0:
        return (0.0, 0.0)
    terms = _walk_terms(components, span)
    entries = mle.Parameterisation.of(components).entries
    gradient = np.array([terms.get(e, 0.0) / (2.0 * k * k) for e in entries])  # ∂ln K/∂ln(parameter)
    try:
        cov, _ = mle.covariance_from_information(whittle.fisher_information(components, n, dt))
    except (InputError, np.linalg.LinAlgError):
        return None
    used = gradient != 0.0
    with np.errstate(invalid="ignore"):
        var = float(gradient[used] @ cov[np.ix_(used, used)] @ gradient[used])
    if not (math.isfinite(var) and 0.0 <= var <= MAX_LOG_SE**2):
        return None
    sd = math.sqrt(var)
    return (k * math.exp(-Z95 * sd), k * math.exp(Z95 * sd))


def _statistic_walk_scale(exact: list[Component], on_statistic: tuple[Component, ...], span_s: float) -> float:
    """How much the exact fit's K exceeds what a statistic of fixed size reads for the same structure
    (:func:`record_walk` of ``exact`` over that of ``on_statistic``, the structure fitted on the statistic); 1 where
    either has no walk or the statistic's fit is not known."""
    k_exact, k_statistic = record_walk(exact, span_s), record_walk(list(on_statistic), span_s)
    return k_exact / k_statistic if k_exact > 0.0 and k_statistic > 0.0 else 1.0


def plausible_walks(selection: SelectionResult, n: int, dt: float) -> list[WalkReading]:
    """The readings of K (:func:`record_walk` of the :func:`visible_components`, :func:`walk_interval`) of the
    selection's structures other than its winner (whose K has its own interval; a structure whose visible components are
    the winner's is the winner) within Occam's window on BIC or AIC (:data:`OCCAM_DELTA`), of a record of ``n`` samples
    at ``dt`` [s], best BIC first: its converged fits, and its candidates screened out on the statistics of fixed size
    (:mod:`..em.screen`) at the components and likelihood gain of each statistic's maximum (their criteria those of the
    structure they were screened against plus the screen's; the block sums may find a slow GM the banded periodogram
    does not see, a mode that reads K differently). A screened candidate's K (and interval) is read relative to the
    statistic's reading of the structure it was screened against (:func:`_statistic_walk_scale`): a statistic of fixed
    size reads K less well than the exact fit, and its absolute K would put its own error into the interval as if it
    were a difference between the structures. ΔBIC and ΔAIC are to the best of all."""
    winner = selection.best_key
    span = n * dt
    fits = {spec: f for spec, f in selection.fits.items() if f.converged}
    found = [(spec, f.bic, f.aic, list(f.components), 1.0) for spec, f in fits.items()]
    found += [(spec if i == 0 else f"{spec} at its {m.statistic} maximum", fits[against].bic + verdict.delta_bic_at(m),
               fits[against].aic + verdict.delta_aic_at(m), list(m.components),
               _statistic_walk_scale(list(fits[against].components), m.reference_components, span))
              for spec, (against, verdict) in selection.screened.items() if against in fits
              for i, m in enumerate(verdict.maxima) if m.components]
    if not found:
        return []
    bic_min, aic_min = min(f[1] for f in found), min(f[2] for f in found)
    winner_structure = _structure(visible_components(list(selection.best.components), n, dt))
    readings = []
    for spec, bic, aic, components, scale in sorted(found, key=lambda f: f[1]):
        if spec == winner or min(bic - bic_min, aic - aic_min) > OCCAM_DELTA:
            continue
        visible = visible_components(components, n, dt)
        if _structure(visible) == winner_structure:
            continue
        ci = walk_interval(visible, n, dt)
        k = record_walk(visible, span)
        readings.append(WalkReading(spec, bic - bic_min, aic - aic_min, scale * k,
                                    None if ci is None else (scale * ci[0], scale * ci[1])))
    return readings


def spannable(k: KalibrValue) -> bool:
    """Whether :func:`over_structures` can widen ``k``: a model's value with a finite interval (a bound stays one)."""
    return k.method == "model" and k.value is not None and all(math.isfinite(v) for v in k.ci95)


def one_sided_upper(value: float, ci95: tuple[float, float]) -> float:
    """The one-sided 95 % upper limit of K [u/s/√Hz] whose two-sided 95 % interval ``ci95`` lies about ``value`` on
    ln K: value·(hi/value)^(Z95_ONE_SIDED/Z95), exact for a Wald interval on ln K (value·exp(±Z95·sd)), the profile's
    quadratic approximation for a profile interval; 0 for a reading of no walk."""
    hi = ci95[1]
    if value <= 0.0 or hi <= value:
        return hi
    return value * math.exp(Z95_ONE_SIDED / Z95 * math.log(hi / value))


def over_structures(k: KalibrValue, readings: list[WalkReading]) -> KalibrValue:
    """``k`` with its interval the hull of its own and every reading's; unchanged when they all lie inside it or
    ``k`` is not :func:`spannable`. Where the hull reaches zero (a structure within the evidence reads no walk): an
    upper bound U, method ``bound``, interval (0, U), U the largest :func:`one_sided_upper` of the final model's and
    the readings' intervals. [0, U] then holds the truth with 95 % probability under whichever structure carries it;
    the two-sided upper ends would make it a 97.5 % interval labelled 95 %. The source names every structure read."""
    lo, hi = k.ci95
    if not readings or not spannable(k):
        return k
    lo_all = min(lo, *(r.span[0] for r in readings))
    hi_all = max(hi, *(r.span[1] for r in readings))
    if lo_all >= lo and hi_all <= hi:
        return k
    told = "; ".join(r.describe() for r in readings)
    if lo_all <= 0.0:
        upper = max(one_sided_upper(k.value, k.ci95), *(one_sided_upper(r.random_walk, r.span) for r in readings))
        return KalibrValue(upper, (0.0, upper), f"{k.source}; the data cannot tell apart {told}: K lies in [0, "
                                                f"{upper:.3g}] (95 %, the largest of the structures' one-sided 95 % "
                                                f"upper limits; the final model's own two-sided interval [{lo:.3g}, "
                                                f"{hi:.3g}]), the upper end given", method="bound")
    return KalibrValue(k.value, (lo_all, hi_all), f"{k.source}; its interval spans the structures the data cannot "
                                                  f"tell apart ({told}; the final model's own [{lo:.3g}, {hi:.3g}])")
