"""Bias instability B [u] from a fitted model, with its interval, and from the AV.

IEEE Std 952: σ_min = √(2 ln 2/π)·B ≈ 0.664 B on the Allan deviation's flat bottom. From the model (beyond the
papers): B = min_τ σ_model(τ)/0.664 over τ ≤ ``tau_max``, narrow OSCs and regressors left out. With a BI component B
is its parameter. Interval: 2.5/97.5 % quantiles of B over log-parameters drawn from N(θ̂, Σ) (unidentified ones held;
one not resolved from zero held below its interval's upper end). Where σ_model still falls at ``tau_max``
(``reached = False``) the minimum lies beyond the record and the data give only a bound: B is then the 95 % upper end
of that reading and its interval (0, B), as a random walk's bound is."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...noise.components import Component, total_allan_variance
from ...noise.modelspec import parameter_labels
from ..em.results import FitResult
from .kalibr import is_short_memory_osc

#: σ_min = FLICKER_FACTOR · B (IEEE Std 952: √(2 ln 2 / π)).
FLICKER_FACTOR = math.sqrt(2.0 * math.log(2.0) / math.pi)
#: Components that are not bias (vibration lines) and stay out of the reading.
NOT_BIAS = ("OSC",)
#: Draws of the parameter distribution for the interval.
N_DRAWS = 200


@dataclass(frozen=True)
class BiasInstability:
    """Bias instability B [u] with its 95 % interval, the τ [s] of the minimum and whether it was reached."""

    value: float
    ci95: tuple[float, float]
    tau_at_minimum: float
    reached: bool
    source: str

    def method(self, reading: str = "model") -> str:
        """``<reading>_minimum``, or ``<reading>_upper_bound`` where the minimum was not reached (imu.yaml's names)."""
        return f"{reading}_minimum" if self.reached else f"{reading}_upper_bound"


def _tau_grid(dt: float, tau_max: float) -> np.ndarray:
    return np.geomspace(dt, max(tau_max, 2.0 * dt), 2000)


def _minimum(components: list[Component], dt: float, tau: np.ndarray) -> tuple[float, float, bool]:
    bias = [c for c in components if c.name not in NOT_BIAS or is_short_memory_osc(c, dt)]
    adev = np.sqrt(np.maximum(total_allan_variance(bias, tau, dt), 0.0))
    k = int(np.argmin(adev))
    return float(adev[k]) / FLICKER_FACTOR, float(tau[k]), k < tau.size - 1


def bias_instability(fit: FitResult, tau_max: float, *, seed: int = 0) -> BiasInstability:
    """B from ``fit`` over τ ∈ [dt, ``tau_max``] [s]."""
    tau = _tau_grid(fit.dt, tau_max)
    flicker = next((c for c in fit.components if c.name == "BI"), None)
    if flicker is not None:
        ci = fit.ci95.get("BI.bias_instability", (math.nan, math.nan))
        _, tau_min, _ = _minimum(list(fit.components), fit.dt, tau)
        return BiasInstability(float(flicker.params()["bias_instability"]), (float(ci[0]), float(ci[1])), tau_min,
                               True,
                               "the model's flicker-noise component BI (IEEE Std 952: PSD B²/(2πf))")
    value, tau_min, reached = _minimum(list(fit.components), fit.dt, tau)
    source = (f"minimum of the model's Allan deviation (without narrow {', '.join(NOT_BIAS)}) / "
              f"{FLICKER_FACTOR:.3f}")
    interval = _interval(fit, tau, seed)
    if not reached:
        source += f"; still falling at τ = {tau_max:.3g} s: an upper bound, the 95 % upper end of that reading"
        value = interval[1] if math.isfinite(interval[1]) else value
        interval = (0.0, interval[1])
    return BiasInstability(value, interval, tau_min, reached, source)


def _interval(fit: FitResult, tau: np.ndarray, seed: int) -> tuple[float, float]:
    """2.5/97.5 % quantiles of B over draws of the log-parameters, one not resolved from zero held below its 95 %
    interval's upper end (:func:`_log_ceilings`; nan when the fit holds no covariance)."""
    labels = list(fit.covariance_labels)
    # Parameters the data do not identify (infinite variance, e.g. a white noise driven to ~0 beside the sensor's
    # low-pass) are held at their estimates.
    index = {lab: i for i, lab in enumerate(labels) if np.isfinite(fit.log_covariance[i, i])}
    slots = [(i, name, lab) for i, name, lab in parameter_labels(list(fit.components)) if lab in index]
    if not slots:
        return (math.nan, math.nan)
    theta = np.array([math.log(fit.components[i].params()[name]) for i, name, _ in slots])
    cov = fit.log_covariance[np.ix_([index[lab] for *_, lab in slots], [index[lab] for *_, lab in slots])]
    draws = np.random.default_rng(seed).multivariate_normal(theta, cov, size=N_DRAWS, method="eigh")
    draws = np.minimum(draws, _log_ceilings(fit, [lab for *_, lab in slots]))
    values = []
    for row in draws:
        comps = list(fit.components)
        updates: dict[int, dict[str, float]] = {}
        for (i, name, _), v in zip(slots, row, strict=True):
            updates.setdefault(i, {})[name] = math.exp(v)
        try:
            comps = [type(c)(**{**c.params(), **updates.get(i, {})}) for i, c in enumerate(comps)]
        except ValueError:  # a draw outside a component's domain (e.g. an OSC too damped)
            continue
        values.append(_minimum(comps, fit.dt, tau)[0])
    if len(values) < N_DRAWS // 2:
        return (math.nan, math.nan)
    lo, hi = np.quantile(values, [0.025, 0.975])
    return (float(lo), float(hi))


def _log_ceilings(fit: FitResult, labels: list[str]) -> np.ndarray:
    """The highest log-value a draw of each parameter ``labels`` names may take: for a parameter not resolved from
    zero (:attr:`~..em.results.FitResult.not_resolved_from_zero`) the logarithm of its interval's finite upper end,
    else +∞. The log-normal draws of such a parameter reach far beyond its profile interval (10⁹⁰ for a walk whose
    interval is [0, 3·10⁻³]), and B's interval would follow them; a resolved parameter's draws are left as drawn."""
    zero = set(fit.not_resolved_from_zero)
    ceilings = np.full(len(labels), np.inf)
    for j, lab in enumerate(labels):
        hi = fit.ci95[lab][1] if lab in zero else math.inf
        if 0.0 < hi < math.inf:
            ceilings[j] = math.log(hi)
    return ceilings


def bias_instability_from_allan(tau: np.ndarray, avar: np.ndarray) -> BiasInstability:
    """min σ(τ)/0.664 of an estimated AV, without interval."""
    ok = np.isfinite(avar) & (avar > 0)
    adev = np.sqrt(avar[ok])
    k = int(np.argmin(adev))
    return BiasInstability(float(adev[k]) / FLICKER_FACTOR, (math.nan, math.nan), float(tau[ok][k]),
                           k < adev.size - 1, "minimum of the data's Allan deviation / 0.664")
