"""Whether an axis's final model may give its N and K, and what is given where it may not.

A final model is *unresolved* for the numbers users paste when

* the closed loop's verdict failed (:attr:`~imu_noise_id.pipelines.loop.LoopResult.passed`): its residuals hold
  evidence no effect explained, so its components are not identified as what they are named; or
* its passband noise density N disagrees with the data's own passband reading, the Allan variance's white-noise
  line (:func:`~imu_noise_id.core.allan.slopes.fit_axis_slopes`): the two 95 % intervals are disjoint and the
  values differ by more than :data:`PASSBAND_FACTOR` (the model put the passband noise in a component N leaves
  out, e.g. a Gauss–Markov process standing for a higher-order sensor filter beside a white noise driven to ~0).

An unresolved axis gives, for both N and K, the values of the overbound of its data
(:func:`~.overbound.data_overbound`: the smallest WN + RW whose Allan variance covers the data's upper confidence
bound over the τ range a filter cares about; the untrusted model's AV is left out) as upper bounds, interval
(0, value), method ``unresolved``, and the reason in its source. The model's
own values stay in ``model.yaml``. Why: ``docs/analysis.md`` ("Why an unresolved axis pastes its overbound").
"""

from __future__ import annotations

import math
from dataclasses import replace

from ...core.allan.slopes import SlopeComponent
from ...core.estimation.kalibr import KalibrValue
from ..loop import LoopResult
from .final import FinalModel
from .overbound import AxisOverbound

#: N and the data's passband reading disagree when their intervals are disjoint and their ratio exceeds this.
PASSBAND_FACTOR = 2.0


def passband_disagreement(n: KalibrValue, reading: SlopeComponent) -> str | None:
    """Why the model's N [u/√Hz] disagrees with the data's white-noise reading (module docstring), or None.

    ``reading`` is the Allan-slope N with its interval; an upper bound (``method="upper_bound"``, interval
    (0, value)) disagrees only with an N above it.
    """
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
