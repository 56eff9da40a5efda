"""The final model of each axis, which the numbers users paste come from: the loop's last step when the loop changed the
model, else the selection (a short-memory GM read as the sensor's low-pass,
:func:`~imu_noise_id.core.estimation.em.relabel.gm_as_filter`). From it N, K (or "not identifiable") and the per-sample
high-frequency variance (:mod:`~..estimation.readouts.kalibr`; lines, filter shape, GMs and regressors kept out),
and the bias instability from the model and the data's AV (:mod:`~..estimation.readouts.instability`); a K above
the data's long-τ bound (:mod:`imu_noise_id.core.allan.rw_bound`) is flagged in its source, and K's interval spans
the readings of the selection's structures within the evidence (:mod:`~..estimation.readouts.walk_evidence`)."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, replace

from ...core.allan import AllanResult
from ...core.allan.rw_bound import RandomWalkBound, random_walk_bound
from ...core.estimation.em.relabel import gm_as_filter, with_uncertainty
from ...core.estimation.em.results import FitResult
from ...core.estimation.em.selection import SelectionResult
from ...core.estimation.readouts import kalibr, walk_evidence
from ...core.estimation.readouts.instability import BiasInstability, bias_instability, bias_instability_from_allan
from ...core.noise.base import Component
from ..loop import LoopResult

#: The components that carry the record's slow part (the walk K is read from): a loop step that changes them makes the
#: selection's evidence on K stale.
WALK_CARRIERS = ("RW", "GM", "BI", "RR")


@dataclass(frozen=True)
class FinalModel:
    """An axis's final model and the Kalibr numbers taken from it.

    Attributes
    ----------
    fit : the final fit (without its record), with intervals
    source : where it comes from, in words
    model : its name in every output: the loop's last step's (regressors and outliers included, e.g. WN+SIN), else the
        fit's
    noise_density, random_walk : N [u/√Hz] and K [u/s/√Hz] with intervals and sources
    noise_stddev_per_sample : √(per-sample high-frequency variance) at the recording's dt [u]
    bias_instability, bias_instability_allan : B [u] from the model (with interval) and from the data's AV
    random_walk_bound : the largest K the AV at τ ≥ a tenth of the record supports (95 %, simultaneous)
    unresolved : why the model is not trusted (:mod:`.resolution`), else None; then ``random_walk`` is the
        overbound's, ``noise_density`` too unless the data's passband level confirms the model's (its method then
        stays ``model``), and ``model_values`` the model's (N, K)
    walk_readings : the readings of K of the selection's structures within the evidence where one of their intervals
        reaches outside the final K's (its interval then spans them, :func:`~..readouts.walk_evidence.over_structures`),
        else empty
    """

    fit: FitResult
    source: str
    model: str
    noise_density: kalibr.KalibrValue
    random_walk: kalibr.KalibrValue
    noise_stddev_per_sample: float
    bias_instability: BiasInstability
    bias_instability_allan: BiasInstability
    random_walk_bound: RandomWalkBound
    unresolved: str | None = None
    model_values: tuple[kalibr.KalibrValue, kalibr.KalibrValue] | None = None
    walk_readings: tuple[walk_evidence.WalkReading, ...] = ()

    @property
    def random_walk_above_bound(self) -> bool:
        """Whether the final K, a model's value (not a bound), is above what the data's long-τ AV supports."""
        return self.random_walk.method == "model" and self.random_walk_bound.exceeded_by(self.random_walk.value)


def _walk_carriers(components: Iterable[Component]) -> list[str]:
    return sorted(c.name for c in components if c.name in WALK_CARRIERS)


def final_model(model_fit: FitResult, loop: LoopResult | None, allan: AllanResult,
                selection: SelectionResult | None = None) -> FinalModel:
    """The final model of one axis from its model-stage fit, its loop and its AV (module docstring): intervals computed
    here unless the loop gave them (:func:`~imu_noise_id.pipelines.loop.run.final_intervals`); a fit short of the
    maximum (:attr:`~imu_noise_id.core.estimation.em.results.FitResult.short_of_maximum`) says so in its sources; B read
    over τ up to a tenth of the record. ``selection``: the model stage's selection that ``model_fit`` won; where the
    final model's components of :data:`WALK_CARRIERS` are the winner's, K's interval spans its structures within the
    evidence (:func:`~..readouts.walk_evidence.plausible_walks`)."""
    if loop is None or len(loop.steps) == 1:
        fit = gm_as_filter(model_fit)
        source = "model selection" + ("" if loop is None else " (the closed loop added nothing)")
    else:
        fit = loop.final.diagnosis.fit
        fit = fit if fit.record_length is not None else with_uncertainty(fit)  # the loop's own, when it gave them
        source = f"closed loop, step {loop.final.index}: {loop.final.model}"
    name = fit.model if loop is None or len(loop.steps) == 1 else loop.final.model
    short = fit.short_of_maximum
    if short is not None:
        source += (f"; not at the likelihood's maximum: its intervals' search met a log-likelihood {short:.3g} "
                   "higher, so the values and intervals are not the maximum's")
    if fit.budget_stop is not None:
        source += f"; {fit.budget_stop_text()}"
    tau_max = fit.n * fit.dt / 10.0
    supported = allan.tau <= tau_max
    bound = random_walk_bound(allan, tau_min=tau_max)
    k = kalibr.unmodelled_as_bound(kalibr.unidentified_as_bound(kalibr.random_walk(fit)), bound)
    n = kalibr.noise_density(fit)
    loop_changed_walk = (loop is not None and len(loop.steps) > 1
                         and _walk_carriers(fit.components) != _walk_carriers(model_fit.components))
    # the readings (each a Fisher information of the record's length) only where they can widen K
    plausible = ([] if selection is None or loop_changed_walk or not walk_evidence.spannable(k)
                 else walk_evidence.plausible_walks(selection, fit.n, fit.dt))
    spanned = walk_evidence.over_structures(k, plausible)
    readings, k = (tuple(plausible) if spanned is not k else ()), spanned
    if k.method == "model" and bound.exceeded_by(k.value):
        k = replace(k, source=f"{k.source}; {bound.excess(k.value)}; a longer record tells them apart")
    if short is not None or fit.budget_stop is not None:
        k, n = (replace(v, source=f"{v.source}; the fit is not at the likelihood's maximum") for v in (k, n))
    return FinalModel(fit=fit.without_data(), source=source, model=name, noise_density=n,
                      random_walk=k, random_walk_bound=bound, walk_readings=readings,
                      noise_stddev_per_sample=math.sqrt(kalibr.per_sample_noise_variance(fit)),
                      bias_instability=bias_instability(fit, tau_max),
                      bias_instability_allan=bias_instability_from_allan(allan.tau[supported],
                                                                         allan.variance[supported, 0]))

