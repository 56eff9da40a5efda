"""The final model of each axis: what the numbers users paste come from.

The closed loop's last step when the loop changed the model (refitted intervals included), else the model stage's
selection; a short-memory GM read as the sensor's low-pass (:func:`~imu_noise_id.core.estimation.relabel.gm_as_filter`).
From it: the passband noise density N, the random walk K (or "not identifiable"), the per-sample variance of the
high-frequency noise (:mod:`imu_noise_id.core.estimation.kalibr`) — oscillations, the internal filter's shape,
GMs and regressors kept out of N and K — and the bias instability, read from the model with its interval and from
the data's Allan deviation (:mod:`imu_noise_id.core.estimation.instability`). A random walk above what the data's
long-τ AV supports (:mod:`imu_noise_id.core.allan.rw_bound`, τ beyond the tenth of the record the model is judged
on) is flagged in its source: a bounded wander fits the record as well, and only a longer record tells them apart.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from ...core.allan import AllanResult
from ...core.allan.rw_bound import RandomWalkBound, random_walk_bound
from ...core.estimation import kalibr
from ...core.estimation.instability import BiasInstability, bias_instability, bias_instability_from_allan
from ...core.estimation.relabel import gm_as_filter, with_uncertainty
from ...core.estimation.results import FitResult
from ..loop import LoopResult


@dataclass(frozen=True)
class FinalModel:
    """An axis's final model and the Kalibr numbers taken from it.

    Attributes
    ----------
    fit : the final fit (without its record), with intervals
    source : where it comes from, in words (model selection, or the loop's step and model)
    model : its name as every output prints it: the loop's last step's (regressors and removed outliers included,
        e.g. WN+SIN, where ``fit.model`` names the stochastic components alone), else the fit's
    noise_density, random_walk : Kalibr's N [u/√Hz] and K [u/s/√Hz] with intervals and their sources
    noise_stddev_per_sample : √(per-sample variance of the high-frequency noise) at the recording's dt [u]
    bias_instability, bias_instability_allan : B [u] from the model (with interval) and from the data's AV
    random_walk_bound : the largest K the data's AV at τ ≥ a tenth of the record supports (95 %, simultaneous)
    unresolved : why the model is not trusted for N and K (:mod:`.resolution`), None when it is; then
        ``noise_density`` and ``random_walk`` are the overbound's and ``model_values`` the model's own (N, K)
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

    @property
    def random_walk_above_bound(self) -> bool:
        """Whether the final K, a model's value, is above what the data's long-τ AV supports."""
        return self.unresolved is None and self.random_walk_bound.exceeded_by(self.random_walk.value)


def final_model(model_fit: FitResult, loop: LoopResult | None, allan: AllanResult) -> FinalModel:
    """The final model of one axis from its model-stage fit, its loop and its Allan variance (module docstring).

    The loop's final fit carries its intervals when the loop was run with ``intervals=True`` (then fitted again
    where they met a higher likelihood, :func:`~imu_noise_id.pipelines.loop.run.final_intervals`), else they are
    computed here. A fit still short of the maximum by more than the 95 % threshold
    (:attr:`~imu_noise_id.core.estimation.results.FitResult.short_of_maximum`) says so in its sources.

    The bias instability is read over τ up to a tenth of the record (where the AV estimates still have ≳ 10
    degrees of freedom), the model's and the data's alike.
    """
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
    tau_max = fit.n * fit.dt / 10.0
    supported = allan.tau <= tau_max
    bound = random_walk_bound(allan, tau_min=tau_max)
    k, n = kalibr.random_walk(fit), kalibr.noise_density(fit)
    if bound.exceeded_by(k.value):
        k = replace(k, source=f"{k.source}; {bound.excess(k.value)}; a longer record tells them apart")
    if short is not None:
        k, n = (replace(v, source=f"{v.source}; the fit is not at the likelihood's maximum") for v in (k, n))
    return FinalModel(fit=fit.without_data(), source=source, model=name, noise_density=n,
                      random_walk=k, random_walk_bound=bound,
                      noise_stddev_per_sample=math.sqrt(kalibr.per_sample_noise_variance(fit)),
                      bias_instability=bias_instability(fit, tau_max),
                      bias_instability_allan=bias_instability_from_allan(allan.tau[supported],
                                                                         allan.variance[supported, 0]))
