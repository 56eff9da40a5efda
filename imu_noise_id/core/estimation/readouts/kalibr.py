"""Kalibr's noise density N and random walk K from a fitted model, with 95 % intervals (beyond paper 000).

- N [u/√Hz] = √(Σ N_i²) over WN, LPF, DLPF, MA and short-memory OSCs, each at its sampled zero-frequency density
  √(dt·Σ_j R(j)); GMs, slow filters, narrow OSCs, BI and sinusoids never enter. Interval by the delta method.
- K [u/s/√Hz]: the RW's density with its interval; None without an RW; a bound where the record does not identify it.
- Per-sample variance [u²]: N_WN²/dt + π N_LPF² f_c + N_MA²/(2 dt) + R_DLPF(0) + σ²_OSC (short-memory OSCs)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ...allan.rw_bound import RandomWalkBound
from ...noise.base import Component
from ...noise.components import DLPF, LPF, MA, OSC, RW, WN
from ...noise.modelspec import parameter_labels
from ...noise.resonant import filter_memory_limit
from ..em.differences import derivative_in_domain
from ..em.results import FitResult
from .quantiles import Z95

#: Log-parameter step of the passband densities' gradients.
GRADIENT_STEP = 1e-6
#: A part of N² below this share does not enter N's interval.
NEGLIGIBLE_SHARE = 1e-6


@dataclass(frozen=True)
class KalibrValue:
    """One Kalibr number of one axis: ``value`` [u/√Hz] or [u/s/√Hz] (None: not identifiable), its 95 % interval
    ``ci95`` ((nan, nan) without uncertainty), its ``source`` in words, and ``method``: ``model``, ``bound`` (not
    identified: the interval's upper end, ``ci95`` (0, value)) or ``unresolved`` (the axis's overbound as upper
    bound, ``ci95`` (0, value))."""

    value: float | None
    ci95: tuple[float, float]
    source: str
    method: str = "model"


def _ci_from_log_sd(value: float, sd: float) -> tuple[float, float]:
    if not math.isfinite(sd):
        return (0.0, math.inf)
    return (value * math.exp(-Z95 * sd), value * math.exp(Z95 * sd))


def _log_cov(fit: FitResult, labels: list[str]) -> np.ndarray | None:
    """The log-parameter covariance of ``labels`` (None if any is missing)."""
    index = {lab: i for i, lab in enumerate(fit.covariance_labels)}
    if not all(lab in index for lab in labels):
        return None
    k = [index[lab] for lab in labels]
    return fit.log_covariance[np.ix_(k, k)]


def is_short_memory_osc(c: Component, dt: float) -> bool:
    """Whether ``c`` is an OSC of decay time 1/(πB) below ``filter_memory_limit(dt)`` (white below its corner: in N)."""
    return isinstance(c, OSC) and c.memory(dt)[0] < filter_memory_limit(dt)


def is_slow_lpf(c: Component, dt: float) -> bool:
    """Whether ``c`` is an LPF/DLPF of memory 1/(2πf_c) ≥ ``filter_memory_limit(dt)`` (a GM in effect: not in N): the
    LPF's sampled pole's decay, the DLPF's 1/(2πf_c) at its −3 dB cutoff f_c whatever its order (a Butterworth's slowest
    pole decays over up to 2.6× that at order 4)."""
    if isinstance(c, DLPF):
        return 1.0 / (2.0 * math.pi * c.cutoff) >= filter_memory_limit(dt)
    return isinstance(c, LPF) and c.memory(dt)[0] >= filter_memory_limit(dt)


def enters_n(c: Component, dt: float) -> bool:
    """Whether ``c`` is white noise or short-memory noise white below its corner (module docstring)."""
    return (isinstance(c, (WN, MA)) or (isinstance(c, (LPF, DLPF)) and not is_slow_lpf(c, dt))
            or is_short_memory_osc(c, dt))


def passband_density(components: list[Component], dt: float) -> float | None:
    """N [u/√Hz] from components alone: √(Σ N_i²) over those entering N, sampled at ``dt`` [s]; None without any."""
    parts = [c.zero_frequency_density(dt) for c in components if enters_n(c, dt)]
    return math.sqrt(sum(d * d for d in parts)) if parts else None


def _passband_part(c: Component, dt: float) -> tuple[float, dict[str, float]] | None:
    """(sampled zero-frequency density [u/√Hz], ∂ln density/∂ln parameter) of a component entering N, else None."""
    if not enters_n(c, dt):
        return None
    density = c.zero_frequency_density(dt)
    params = c.params()

    def log_density(name: str, h: float) -> float:
        return math.log(replace(c, **{name: params[name] * math.exp(h)}).zero_frequency_density(dt))

    gradient = {}
    for name in c.parameter_names:
        d = derivative_in_domain(lambda h, name=name: log_density(name, h), GRADIENT_STEP, lambda: math.log(density))
        if d is not None and abs(float(d)) > 1e-9:
            gradient[name] = float(d)
    return density, gradient


def _describe(c: Component, tag: str, dt: float) -> str:
    if isinstance(c, OSC):
        return (f"{tag} ({c.frequency:.3g} Hz, bandwidth {c.bandwidth:.3g} Hz: a memory of "
                f"{1e3 * c.memory(dt)[0]:.2g} ms, white below it)")
    return tag


def noise_density(fit: FitResult) -> KalibrValue:
    """Passband white-noise density N = √(Σ N_i²) over the WN and the short-memory noise (module docstring)."""
    labels_of = {(i, p): lab for i, p, lab in parameter_labels(fit.components)}
    parts = [(i, c, part) for i, c in enumerate(fit.components) if (part := _passband_part(c, fit.dt)) is not None]
    if not parts:
        return KalibrValue(None, (math.nan, math.nan), "the model has no white noise")
    n = math.sqrt(sum(part[0] ** 2 for _, _, part in parts))
    tags = [_describe(c, labels_of[i, c.parameter_names[0]].split(".")[0], fit.dt) for i, c, _ in parts]
    if len(parts) == 1:
        source = tags[0] if tags[0] == "WN" else f"{tags[0]} (passband density)"
    else:
        what = ("the white noise and the short-memory noise, white below its corner"
                if any(isinstance(c, OSC) for _, c, _ in parts) else "the sensor's own filter on its white noise")
        source = f"{' and '.join(tags)} combined ({what}): sqrt of the sum of the squared passband densities"
    gradient0 = parts[0][2][1]
    label0 = labels_of[parts[0][0], next(iter(gradient0))]
    if len(parts) == 1 and len(gradient0) == 1 and label0 in fit.ci95:
        return KalibrValue(n, tuple(fit.ci95[label0]), source)
    # Delta method on ln N = ½ ln Σ N_i²: ∂ln N/∂ln p = Σ_i (N_i²/N²) ∂ln N_i/∂ln p. A part holding less than
    # NEGLIGIBLE_SHARE of N² (a white noise driven to ~0 beside the low-pass, whose own interval is then
    # uninformative) is left out.
    kept = [(i, density, slopes) for i, _, (density, slopes) in parts if density**2 >= NEGLIGIBLE_SHARE * n * n]
    gradient = {labels_of[i, p]: density**2 / (n * n) * e for i, density, slopes in kept for p, e in slopes.items()}
    cov = _log_cov(fit, list(gradient))
    if cov is not None:
        g = np.fromiter(gradient.values(), float)
        with np.errstate(invalid="ignore"):
            var = float(g @ np.where(np.outer(g, g) != 0, cov, 0.0) @ g)
        if math.isfinite(var):
            return KalibrValue(n, _ci_from_log_sd(n, math.sqrt(max(var, 0.0))), source)
    # Without a usable covariance: each part's interval from its parameters' own interval ends (the end that
    # lowers N_i for the lower limit; N_i linearised in the log-parameters), combined end to end,
    # √(Σ lo_i²) … √(Σ hi_i²) (as if fully correlated).
    los, his = [], []
    for i, density, slopes in kept:
        lo = hi = density
        for p, e in slopes.items():
            ends = fit.ci95.get(labels_of[i, p])
            if ends is None:
                return KalibrValue(n, (math.nan, math.nan), source)
            value = fit.components[i].params()[p]
            low, high = (min(ends), max(ends)) if e > 0 else (max(ends), min(ends))
            lo *= _power_ratio(low, value, e)
            hi *= _power_ratio(high, value, e)
        los.append(lo)
        his.append(hi)
    return KalibrValue(n, (math.hypot(*los), math.hypot(*his)), source)


def _power_ratio(end: float, value: float, exponent: float) -> float:
    """(end/value)^exponent, with an interval end at 0 giving 0 (exponent > 0) or ∞ (exponent < 0)."""
    if end > 0:
        return (end / value) ** exponent
    return 0.0 if exponent > 0 else math.inf


def random_walk(fit: FitResult) -> KalibrValue:
    """The RW's density K with its interval, or ``value=None`` when the model has no RW (module docstring)."""
    rw = next((c for c in fit.components if isinstance(c, RW)), None)
    if rw is None:
        return KalibrValue(None, (math.nan, math.nan), "not identifiable from this record: the final model has no "
                                                       "random walk")
    return KalibrValue(rw.random_walk, tuple(fit.ci95.get("RW.random_walk", (math.nan, math.nan))), "RW")


def per_sample_noise_variance(fit: FitResult) -> float:
    """Variance per sample [u²] of the high-frequency noise at the fit's dt (module docstring)."""
    total = 0.0
    for c in fit.components:
        if isinstance(c, WN):
            total += c.noise_density**2 / fit.dt
        elif isinstance(c, LPF) and not is_slow_lpf(c, fit.dt):
            total += math.pi * c.noise_density**2 * c.cutoff
        elif isinstance(c, (MA, DLPF)) and not is_slow_lpf(c, fit.dt):
            total += c.per_sample(fit.dt)["sigma2_per_sample"]
        elif is_short_memory_osc(c, fit.dt):
            total += c.sigma**2
    return total


def unidentified_as_bound(k: KalibrValue) -> KalibrValue:
    """``k`` when its 95 % interval excludes zero, else its upper end as a ``bound`` with interval (0, upper end)."""
    if k.value is None or not (k.ci95[0] <= 0.0 and math.isfinite(k.ci95[1]) and k.ci95[1] > 0.0):
        return k
    hi = float(k.ci95[1])
    return KalibrValue(hi, (0.0, hi), f"{k.source}; not identified by this record: its 95 % interval [0, {hi:.3g}] "
                                      f"reaches zero (the fitted {k.value:.3g} is one of the values it allows), the "
                                      "upper end given", method="bound")


def unmodelled_as_bound(k: KalibrValue, bound: RandomWalkBound) -> KalibrValue:
    """K of a model without RW (``k.value`` None), or whose 95 % interval reaches zero without a finite upper end (the
    fit bounds it on neither side): the largest K the data's long-τ AV supports
    (:func:`~imu_noise_id.core.allan.rw_bound.random_walk_bound`), method ``bound``, interval (0, bound); else ``k``."""
    unbounded = k.value is not None and k.ci95[0] <= 0.0 and not math.isfinite(k.ci95[1])
    if not (k.value is None or unbounded) or not (math.isfinite(bound.value) and bound.value > 0):
        return k
    fitted = (f"; not identified by this record: the fitted {k.value:.3g} has the interval [0, {k.ci95[1]:.3g}]"
              if unbounded else "")
    return KalibrValue(
        bound.value, (0.0, bound.value),
        f"{k.source}{fitted}; bounded by the data: the largest walk the Allan variance at tau {bound.tau_range[0]:.3g}–"
        f"{bound.tau_range[1]:.3g} s supports ({100 * bound.level:.0f} %, simultaneous over {bound.estimates} "
        f"estimates, {bound.worth()}), the upper end given", method="bound")


def walk_crossing_tau(noise_density: float, random_walk: float) -> float:
    """τ [s] = √3·N/K where the RW's AV K²τ/3 meets the white noise's N²/τ (IEEE Std 952); inf without a walk."""
    return math.sqrt(3.0) * noise_density / random_walk if random_walk > 0 else math.inf
