"""Whether an axis's final model may give its N and K, and what is given where it may not.

Unresolved: the loop's verdict failed (:attr:`~imu_noise_id.pipelines.loop.LoopResult.passed`), or N disagrees with the
AV's white-noise line (:func:`~imu_noise_id.core.allan.slopes.fit_axis_slopes`: 95 % intervals disjoint and values more
than :data:`PASSBAND_FACTOR` apart). An unresolved axis gives its data overbound's N and K
(:func:`~.overbound.data_overbound`) as upper bounds, interval (0, value), method ``unresolved``, the reason in its
source; ``model.yaml`` keeps the model's own. Reasons: docs/analysis.md, "Why an unresolved axis …".
"""

from __future__ import annotations

import math
from dataclasses import replace

from ...core.allan.slopes import SlopeComponent
from ...core.estimation.readouts.kalibr import KalibrValue
from ..loop import LoopResult
from .final import FinalModel
from .overbound import AxisOverbound

#: N and the data's passband reading disagree when their intervals are disjoint and their ratio exceeds this.
PASSBAND_FACTOR = 2.0


def passband_disagreement(n: KalibrValue, reading: SlopeComponent) -> str | None:
    """Why the model's N [u/√Hz] disagrees with the Allan-slope ``reading`` (module docstring), or None; an upper-bound
    reading (interval (0, value)) disagrees only with an N above it."""
    if n.value is None or not reading.value > 0:
        return None
    lo, hi = (n.value if math.isnan(v) else v for v in n.ci95)  # no interval: the value itself
    r_lo, r_hi = (0.0, reading.value) if reading.method == "upper_bound" else reading.ci
    below = hi < r_lo and n.value * PASSBAND_FACTOR < reading.value
    above = lo > r_hi and n.value > PASSBAND_FACTOR * reading.value
    if not (below or above):
        return None
    return (f"its N {n.value:.3g} ({n.source}) is {n.value / reading.value:.3g} times the data's passband level "
            f"{reading.value:.3g} [{r_lo:.3g}, {r_hi:.3g}] (the Allan variance's white-noise line), outside both "
            "intervals")


def unresolved_reason(final: FinalModel, loop: LoopResult | None, reading: SlopeComponent) -> str | None:
    """Why ``final`` may not give N and K (module docstring), or None when it may."""
    reasons = []
    if loop is not None and not loop.passed:
        reasons.append(f"the closed loop's verdict failed ({loop.verdict})")
    disagreement = passband_disagreement(final.noise_density, reading)
    if disagreement is not None:
        reasons.append(disagreement)
    return "; ".join(reasons) or None


def resolved(final: FinalModel, reason: str | None, overbound: AxisOverbound) -> FinalModel:
    """``final`` as it is when ``reason`` is None, else with N and K its overbound's values (module docstring)."""
    if reason is None:
        return final

    def bound(value: KalibrValue, upper: float, name: str) -> KalibrValue:
        model = "none" if value.value is None else f"{value.value:.3g}"
        return KalibrValue(upper, (0.0, upper), f"unresolved: {reason}; given: the overbound's {name} (an upper bound "
                                                f"over τ {overbound.tau_range[0]:.3g}–{overbound.tau_range[1]:.3g} s; "
                                                f"the model's {model} is in model.yaml)", method="unresolved")

    return replace(final, noise_density=bound(final.noise_density, overbound.noise_density, "N"),
                   random_walk=bound(final.random_walk, overbound.random_walk, "K"), unresolved=reason,
                   model_values=(final.noise_density, final.random_walk),
                   source=f"{final.source}; N and K unresolved: {reason}")
