"""Whether an axis's final model may give its N and K, and what is given where it may not.

Unresolved: the loop's verdict failed (:attr:`~imu_noise_id.pipelines.loop.LoopResult.passed`), or N disagrees with
the data's passband level (:func:`passband_disagreement`: 95 % intervals disjoint and values more than
:data:`PASSBAND_FACTOR` apart). The level is the record's spectrum in the band the model's white noise and filter
dominate (:func:`~imu_noise_id.core.estimation.readouts.passband.passband_level`); the AV's white-noise line
(:func:`~imu_noise_id.core.allan.slopes.fit_axis_slopes`) stands in where that band is too narrow. An unresolved axis
gives its data overbound's K (:func:`~.overbound.data_overbound`) as an upper bound, interval (0, value), method
``unresolved``, the reason in its source; it gives the overbound's N the same way unless the verdict alone failed and
the model's N lies inside the 95 % interval of the data's passband level or within :data:`PASSBAND_TOLERANCE` of it:
N then keeps the model's value and interval (widened to span the level's when outside it), its source saying why.
``model.yaml`` keeps the model's own. Reasons: docs/analysis.md, "Why an unresolved axis …".
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from ...core.allan.slopes import SlopeComponent
from ...core.estimation.readouts.kalibr import KalibrValue
from ...core.estimation.readouts.passband import PassbandLevel
from ..loop import LoopResult
from .final import FinalModel
from .overbound import AxisOverbound, data_overbound
from .static import StaticAnalysis

#: N and the data's passband reading disagree when their intervals are disjoint and their ratio exceeds this.
PASSBAND_FACTOR = 2.0


def passband_disagreement(n: KalibrValue, reading: SlopeComponent | PassbandLevel) -> str | None:
    """Why the model's N [u/√Hz] disagrees with the data's ``reading`` (module docstring: the passband level, or the
    Allan-slope white-noise line), or None; an upper-bound reading (interval (0, value)) disagrees only with an N above
    it."""
    if n.value is None or not reading.value > 0:
        return None
    lo, hi = (n.value if math.isnan(v) else v for v in n.ci95)  # no interval: the value itself
    r_lo, r_hi = (0.0, reading.value) if reading.method == "upper_bound" else reading.ci
    below = hi < r_lo and n.value * PASSBAND_FACTOR < reading.value
    above = lo > r_hi and n.value > PASSBAND_FACTOR * reading.value
    if not (below or above):
        return None
    return (f"its N {n.value:.3g} ({n.source}) is {n.value / reading.value:.3g} times the data's "
            f"{_describe(reading)}, outside both intervals")


#: A model's N within this relative distance of the data's passband level is confirmed by it though outside the
#: level's interval: on long records that interval is a fraction of a percent wide, narrower than a misspecified
#: model's N can come (docs/analysis.md, "Why an unresolved axis …"); the N pasted then spans the level.
PASSBAND_TOLERANCE = 0.03


def passband_confirms(n: KalibrValue, level: SlopeComponent | PassbandLevel) -> bool:
    """Whether the model's N [u/√Hz] lies inside the 95 % interval of the data's ``level`` (a reading, not an upper
    bound) or within :data:`PASSBAND_TOLERANCE` of its value."""
    lo, hi = level.ci
    if n.value is None or level.method == "upper_bound" or not 0.0 < lo <= hi:
        return False
    return lo <= n.value <= hi or abs(n.value / level.value - 1.0) <= PASSBAND_TOLERANCE


def _kept(n: KalibrValue, level: SlopeComponent | PassbandLevel, reason: str) -> KalibrValue:
    """The model's N confirmed by ``level`` (:func:`passband_confirms`) as pasted: its value and interval when it lies
    inside the level's interval, else its value with the hull of both intervals; the source saying why."""
    lo, hi = level.ci
    if lo <= n.value <= hi:
        ci, where, spans = n.ci95, f"inside the data's {_describe(level)}", ""
    else:
        ends = [v for v in n.ci95 if not math.isnan(v)]
        ci = (min([lo, *ends]), max([hi, *ends]))
        where = f"within {100 * abs(n.value / level.value - 1.0):.1f} % of the data's {_describe(level)}"
        spans = " (the interval given spans both)"
    return replace(n, ci95=ci, source=f"{n.source}; the model is unresolved ({reason}), but its N lies {where}, read "
                                      f"without the model's structure{spans}")


def _describe(level: SlopeComponent | PassbandLevel) -> str:
    if isinstance(level, PassbandLevel):
        return f"passband level ({level.describe()})"
    if level.method == "upper_bound":
        return f"white-noise line, an upper bound {level.value:.3g} (the Allan variance's)"
    return f"white-noise line {level.value:.3g} [{level.ci[0]:.3g}, {level.ci[1]:.3g}] (the Allan variance's)"


@dataclass(frozen=True)
class Unresolved:
    """Why an axis's final model may not give K (and N, unless ``noise_density_kept``, confirmed by ``level``):
    module docstring."""

    reason: str
    noise_density_kept: bool
    level: SlopeComponent | PassbandLevel | None = None


def unresolved_reason(final: FinalModel, loop: LoopResult | None, reading: SlopeComponent,
                      level: PassbandLevel | None = None) -> Unresolved | None:
    """Why ``final`` may not give its K and perhaps N (module docstring), or None when it may give both; ``reading``
    is the AV's white-noise line, ``level`` the spectrum's passband level (the line judges N without it)."""
    failed = loop is not None and not loop.passed
    confirm = level if level is not None else reading
    disagreement = passband_disagreement(final.noise_density, confirm)
    reasons = [f"the closed loop's verdict failed ({loop.verdict})"] if failed else []
    if disagreement is not None:
        reasons.append(disagreement)
    if not reasons:
        return None
    kept = disagreement is None and passband_confirms(final.noise_density, confirm)
    return Unresolved("; ".join(reasons), kept, confirm if kept else None)


def resolved(final: FinalModel, unresolved: Unresolved | None, overbound: AxisOverbound) -> FinalModel:
    """``final`` as it is when ``unresolved`` is None, else with K (and N unless kept) its overbound's values
    (module docstring)."""
    if unresolved is None:
        return final
    reason = unresolved.reason

    def bound(value: KalibrValue, upper: float, name: str) -> KalibrValue:
        model = ("none" if value.value is None else f"{value.value:.3g}"
                 + (" (an upper bound)" if value.method == "bound" else ""))
        return KalibrValue(upper, (0.0, upper), f"unresolved: {reason}; given: the overbound's {name} (an upper bound "
                                                f"over τ {overbound.tau_range[0]:.3g}–{overbound.tau_range[1]:.3g} s; "
                                                f"the model's {model} is in model.yaml)", method="unresolved")

    n = final.noise_density
    if unresolved.noise_density_kept:
        n = _kept(n, unresolved.level, reason)
        what = "K unresolved (N confirmed by the data's passband level)"
    else:
        n = bound(n, overbound.noise_density, "N")
        what = "N and K unresolved"
    return replace(final, noise_density=n, random_walk=bound(final.random_walk, overbound.random_walk, "K"),
                   unresolved=reason, model_values=(final.noise_density, final.random_walk),
                   source=f"{final.source}; {what}: {reason}")


def resolve_axis(final: FinalModel, loop: LoopResult | None, static: StaticAnalysis, axis: str,
                 level: PassbandLevel | None, *, horizon_s: float) -> tuple[FinalModel, AxisOverbound, str] | None:
    """The resolution of ``axis`` (module docstring; ``level`` the record's ``passband_level`` in ``final``'s band,
    ``horizon_s`` the overbound's [s]): None when its final model gives N and K, else (the final model with the values
    given, the data overbound they come from, the warning)."""
    why = unresolved_reason(final, loop, static.slopes[axis].noise_density, level)
    if why is None:
        return None
    overbound = data_overbound(static, axis, horizon_s)
    given = resolved(final, why, overbound)
    if not why.noise_density_kept:
        return given, overbound, (f"{axis}: N and K unresolved, the overbound's values given (upper bounds): "
                                  f"{why.reason}")
    overbound = replace(overbound, reference_noise_density=final.noise_density.value,
                        reference_source="final model (N, confirmed by the data's passband level); this overbound (K: "
                                         "the final model is unresolved)")
    return given, overbound, (f"{axis}: K unresolved, the overbound's K given (an upper bound); N is the model's, "
                              f"confirmed by the data's {_describe(why.level)}: {why.reason}")
