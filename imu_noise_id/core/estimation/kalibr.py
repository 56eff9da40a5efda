"""The numbers users paste (Kalibr's noise density N and random walk K) from a fitted model, with intervals.

Beyond paper 000, which fits the components but leaves what a WN+RW filter should be told to the user. A model
fitted to a real sensor holds more than WN and RW: the sensor's own low-pass filter (LPF), narrow-band
oscillations (OSC), Gauss–Markov bias processes, sinusoids. Kept out of N and K, they are reported on their own:

- **N** is the passband white-noise density, √(N_WN² + N_LPF² + N_MA²) [u/√Hz] (the sensor's low-pass LPF or
  averaging filter MA on part of its white noise): what a filter integrating the IMU sees at low frequency. An OSC,
  a GM, flicker noise (BI) or a sinusoid never enters it.
- **K** is the RW's density [u/s/√Hz], or *not identifiable from this record* when the final model has no RW (the
  caller then gives the Allan-slope bound).
- The **per-sample variance** of the high-frequency noise at the sampling period dt is
  N_WN²/dt + π N_LPF² f_c + N_MA²/(2 dt): smaller than N²/dt where the sensor's filter cuts below the Nyquist
  frequency — what a consumer of the corrected IMU stream must put in its covariance.

Intervals: 95 %, from the fit's log-parameter covariance by the delta method for N (a sum of components), the
fit's own intervals otherwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..noise.components import LPF, MA, RW, WN
from .results import FitResult

Z95 = 1.959963984540054
#: A part of N² below this share does not enter N's interval.
NEGLIGIBLE_SHARE = 1e-6


@dataclass(frozen=True)
class KalibrValue:
    """One Kalibr number of one axis.

    Attributes
    ----------
    value : the number [u/√Hz or u/s/√Hz]; None when not identifiable from the record
    ci95 : its 95 % interval (lo, hi); (nan, nan) when the fit holds no uncertainty
    source : which components it comes from, in words
    """

    value: float | None
    ci95: tuple[float, float]
    source: str


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


#: The components whose noise is white in the passband: the white noise and the sensor's own filters on it.
PASSBAND = ("WN", "LPF", "MA")


def noise_density(fit: FitResult) -> KalibrValue:
    """Passband white-noise density N = √(N_WN² + N_LPF² + N_MA²) of the fit (module docstring)."""
    parts = [c for c in fit.components if c.name in PASSBAND]
    if not parts:
        return KalibrValue(None, (math.nan, math.nan), "the model has no white noise")
    densities = [c.params()["noise_density"] for c in parts]
    n = math.sqrt(sum(d * d for d in densities))
    filters = [c.name for c in parts if c.name != "WN"]
    source = "WN" if not filters else (f"{filters[0]} (passband density)" if len(parts) == 1 else
                                       f"{' and '.join(c.name for c in parts)} combined (the sensor's own filter "
                                       "on its white noise): sqrt of the sum of the squared passband densities")
    labels_all = [f"{c.name}.noise_density" for c in parts]
    if len(parts) == 1 and labels_all[0] in fit.ci95:
        return KalibrValue(n, tuple(fit.ci95[labels_all[0]]), source)
    # Gradient of ln N = ½ ln Σ N_i² in the ln N_i: the shares of N² (delta method). A part holding less than
    # NEGLIGIBLE_SHARE of N² (a white noise driven to ~0 beside the low-pass, whose own interval is then
    # uninformative) is left out.
    labels, grad = [], []
    for lab, part in zip(labels_all, densities, strict=True):
        if part * part >= NEGLIGIBLE_SHARE * n * n:
            labels.append(lab)
            grad.append(part * part / (n * n))
    cov = _log_cov(fit, labels)
    if cov is not None:
        g = np.asarray(grad)
        with np.errstate(invalid="ignore"):
            var = float(g @ np.where(np.outer(g, g) > 0, cov, 0.0) @ g)
        if math.isfinite(var):
            return KalibrValue(n, _ci_from_log_sd(n, math.sqrt(max(var, 0.0))), source)
    # A part without a Wald interval (e.g. a white noise next to 0 beside the low-pass): combine the parts' own
    # intervals end to end, √(Σ lo_i²) … √(Σ hi_i²) (conservative: as if fully correlated).
    ends = [fit.ci95.get(lab) for lab in labels]
    if any(e is None for e in ends):
        return KalibrValue(n, (math.nan, math.nan), source)
    return KalibrValue(n, (math.hypot(*(e[0] for e in ends)), math.hypot(*(e[1] for e in ends))), source)


def random_walk(fit: FitResult) -> KalibrValue:
    """The RW's density K with its interval, or ``value=None`` when the model has no RW (module docstring)."""
    rw = next((c for c in fit.components if isinstance(c, RW)), None)
    if rw is None:
        return KalibrValue(None, (math.nan, math.nan), "not identifiable from this record: the final model has no "
                                                       "random walk")
    return KalibrValue(rw.random_walk, tuple(fit.ci95.get("RW.random_walk", (math.nan, math.nan))), "RW")


def per_sample_noise_variance(fit: FitResult) -> float:
    """Variance per sample [u²] of the high-frequency noise at the fit's dt: N_WN²/dt + π N_LPF² f_c + N_MA²/(2 dt)."""
    total = 0.0
    for c in fit.components:
        if isinstance(c, WN):
            total += c.noise_density**2 / fit.dt
        elif isinstance(c, LPF):
            total += math.pi * c.noise_density**2 * c.cutoff
        elif isinstance(c, MA):
            total += c.per_sample(fit.dt)["sigma2_per_sample"]
    return total
