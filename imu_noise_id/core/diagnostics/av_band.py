"""The data's Allan-variance band under the null "the model holds": the estimator's exact variance for the model.

The closed loop judges a model by whether its AV lies inside the data's 95 % band at every τ, and its do-no-harm
rule by the misfit z-scores ln(AV_data / AV_model) / sd(ln AV_hat). The textbook band (NIST SP1065, paper 000
section 2) takes the estimate's equivalent degrees of freedom (EDF) from a power-law noise type read off the local
slope. Where a spectral line dominates the AV (a vibration, the ADIS16405 accelerometers' 0.565 Hz disturbance) the
estimate rests on a few cycles of one narrow-band process, not on the M nearly independent differences a power
law would give: with the EDF of the local slope, a *correct* model of WN + a 0.565 Hz line + a 10.8 Hz vibration
leaves the pointwise 95 % band at τ = 0.1–1.3 s in 70–82 % of simulated records, its z-scores with a standard
deviation of 5–13 instead of 1 (``test/test_av_band.py``). Beyond the papers, the EDF here is the model's own.

For a Gaussian model whose rate samples y have partial sums x_k = y_0 + … + y_{k−1} with generalised covariance
K(u) (:meth:`~imu_noise_id.core.noise.base.Component.sum_covariance`), the overlapping AV at m samples,
AV_hat = (1/2M) Σ_k d_k², M = N − 2m + 1, is built from the differences of adjacent m-sample means
d_k = (x_{k+2m} − 2x_{k+m} + x_k)/m, whose covariance at lag l is

    c(l) = [6K(l) − 4K(l − m) − 4K(l + m) + K(l − 2m) + K(l + 2m)] / m²

(the autocorrelation (1, −4, 6, −4, 1) of the second difference (1, −2, 1); it cancels the even polynomial K is
defined up to). With Cov(X², Y²) = 2 Cov(X, Y)² for Gaussian X, Y, and a mean μ = ω·m·dt of d_k from a rate ramp ω,

    E[AV_hat] = (c(0) + μ²)/2,    Var(AV_hat) = (1/4M²) Σ_{|l|<M} (M − |l|) (2c(l)² + 4μ² c(l)),

exact at finite N, and the EDF is ν = 2 E² / Var, the number of degrees of freedom of the χ²_ν/ν that has the
estimate's mean and variance. The band is the χ² interval with that ν (NIST SP1065 eq. 45), as the textbook one is.
"""

from __future__ import annotations

import numpy as np

from ..allan import chi2_interval
from ..noise.components import RR, Component

#: v_j for j = −2 … 2: the autocorrelation of the second difference (1, −2, 1).
_V = (1.0, -4.0, 6.0, -4.0, 1.0)


def model_av_edf(components: list[Component], m: np.ndarray, n: int, dt: float) -> np.ndarray:
    """EDF of the overlapping AV estimates at averaging factors ``m`` of an ``n``-sample record, when the record is
    the Gaussian model ``components`` sampled at ``dt`` [s] (module docstring).

    The components whose increments are uncorrelated beyond a sample or two (WN, QN, MA, RW: no decay time,
    :meth:`~imu_noise_id.core.noise.base.Component.memory`) give c(l) = 0 beyond 2m + 1 lags, and are summed only
    up to there: a random walk's K grows as |u|³, and the five-term difference of values near N³ would otherwise
    leave rounding noise at every lag that the sum of squares collects.
    """
    m = np.asarray(m, dtype=np.int64)
    stochastic = [c for c in components if not isinstance(c, RR)]
    slope = sum(abs(c.slope) for c in components if isinstance(c, RR))
    lags = np.arange(n + 1, dtype=float)
    long_memory, short_memory = [], []
    for c in stochastic:
        (long_memory if c.memory(dt)[0] > 0 else short_memory).append(c)
    k_long = np.sum([c.sum_covariance(lags, dt) for c in long_memory], axis=0) if long_memory else None
    edf = np.empty(m.size)
    for i, mi in enumerate(m):
        count = n - 2 * int(mi) + 1
        ell = np.arange(count)
        c = np.zeros(count)
        if k_long is not None:
            c += _difference_covariance(k_long, ell, int(mi))
        near = ell[: min(count, 2 * int(mi) + 2)]
        for comp in short_memory:
            k_short = comp.sum_covariance(np.arange(near.size + 2 * int(mi) + 1, dtype=float), dt)
            c[: near.size] += _difference_covariance(k_short, near, int(mi))
        mu = slope * float(mi) * dt
        weight = (count - ell).astype(float)
        weight[1:] *= 2.0  # l and −l
        var = float(np.sum(weight * (2.0 * c**2 + 4.0 * mu * mu * c))) / (4.0 * count * count)
        mean = 0.5 * (float(c[0]) + mu * mu)
        edf[i] = 2.0 * mean * mean / var if var > 0 else np.inf
    return edf


def _difference_covariance(k: np.ndarray, ell: np.ndarray, m: int) -> np.ndarray:
    """c(l) at lags ``ell`` = 0, 1, …, L − 1 from K at 0, 1, 2, … (``k``; K is even) for m-sample means (module
    docstring): by index for l < 2m, where l − jm changes sign, and by contiguous slices beyond."""
    size = ell.size
    head = min(size, 2 * m)
    c = np.empty(size)
    c[:head] = sum(v * k[np.abs(ell[:head] + j * m)] for v, j in zip(_V, range(-2, 3), strict=True))
    if size > head:
        c[head:] = sum(v * k[head + j * m: size + j * m] for v, j in zip(_V, range(-2, 3), strict=True))
    return c / float(m) ** 2


def model_av_band(av_data: np.ndarray, components: list[Component], m: np.ndarray, n: int, dt: float, *,
                  confidence: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """The (low, high) ``confidence`` interval [u²] of the data's AV estimates ``av_data`` at ``m``, with the EDF
    of :func:`model_av_edf` (the χ² interval of NIST SP1065 eq. 45)."""
    edf = np.maximum(model_av_edf(components, m, n, dt), 1.0)
    return chi2_interval(np.asarray(av_data, dtype=float), edf, confidence)
