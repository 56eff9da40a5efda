"""The data's AV band under the null "the model holds", with the estimator's exact EDF for the model (NIST SP1065 and
paper 000 sec. 2 take it from the local slope; why: docs/diagnostics.md).

With K(u) the partial sums' generalised covariance (:meth:`~..noise.base.Component.sum_covariance`) and d_k =
(x_{k+2m} − 2x_{k+m} + x_k)/m, the overlapping AV_hat = (1/2M) Σ_k d_k², M = N − 2m + 1, has lag-l covariance c(l) =
[6K(l) − 4K(l − m) − 4K(l + m) + K(l − 2m) + K(l + 2m)]/m²; with a ramp's mean μ = ω·m·dt of d_k, E[AV_hat] = (c(0) +
μ²)/2, Var(AV_hat) = (1/4M²) Σ_{|l|<M} (M − |l|)(2c(l)² + 4μ²c(l)); ν = 2E²/Var, the band the χ²_ν interval (SP1065
eq. 45)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from ..allan import chi2_interval
from ..constants import CONFIDENCE_95
from ..noise.components import RR, Component, total_allan_variance
from ..noise.sampled import consecutive_block_sum_variance, lag_weighted_sum

#: v_j for j = −2 … 2: the autocorrelation of the second difference (1, −2, 1).
_V = (1.0, -4.0, 6.0, -4.0, 1.0)


#: Decay times beyond which a stationary component's autocovariance is below e⁻⁴⁰ of its variance: the K of its
#: partial sums is linear in the lag from there on (to that precision).
MEMORY_REACH = 40.0


def model_av_edf(components: list[Component], m: np.ndarray, n: int, dt: float) -> np.ndarray:
    """EDF of the overlapping AV at factors ``m`` of ``n`` samples at ``dt`` [s] of the Gaussian model
    ``components``.

    c(l) is summed directly over the lags where a component without :meth:`~..noise.base.Component.exponential_terms`
    still correlates d_k (l < 2m + its reach: white noise, a walk and a moving average end at 2m + 2, a digital
    low-pass :data:`MEMORY_REACH` decay times later). Beyond, only exponential terms R(u) = Re Σ_j c_j e^{s_j u} remain,
    and with z_j = e^{s_j dt}, l' = l − 2m + 1:

        c(l) = Σ_j Re(Γ_j z_j^{l'}),  Γ_j = −c_j (1 − z_j^m)⁴ / (m² (1 − z_j)²),

    so Σ_l (M − l) c(l) and Σ_l (M − l) c(l)² are geometric sums in closed form (:func:`_tail_sums`): O(J²) per m for
    J terms instead of O(N). Beyond the papers."""
    m = np.asarray(m, dtype=np.int64)
    stochastic = [c for c in components if not isinstance(c, RR)]
    slope = sum(abs(c.slope) for c in components if isinstance(c, RR))
    exponential, terms, finite, short_memory = [], [], [], []
    for c in stochastic:
        if (its_terms := c.exponential_terms()) is not None:
            exponential.append(c)
            terms.append(its_terms)
        elif c.memory(dt)[0] > 0:
            finite.append(c)
        else:
            short_memory.append(c)
    reach = max([2, *(_reach(c, n + 1, dt) for c in finite)])
    weights = np.concatenate([t[0] for t in terms]) if terms else np.zeros(0, complex)
    poles = np.concatenate([t[1] for t in terms]) * dt if terms else np.zeros(0, complex)
    direct = [min(n - 2 * int(mi) + 1, 2 * int(mi) + reach) for mi in m]
    size = min(n + 1, max((d + 2 * int(mi) + 1 for d, mi in zip(direct, m, strict=True)), default=1))
    long_memory = exponential + finite
    k_long = np.sum([_sum_covariance(c, size, dt) for c in long_memory], axis=0) if long_memory else None
    edf = np.empty(m.size)
    for i, mi in enumerate(int(v) for v in m):
        count = n - 2 * mi + 1
        ell = np.arange(direct[i])
        c = _difference_covariance(k_long, ell, mi) if k_long is not None else np.zeros(ell.size)
        # uncorrelated beyond a sample or two: c(l) = 0 from l = 2m + 2, K read near 0 (no cancellation of a walk's
        # cubic K at long lags)
        near = ell[: min(ell.size, 2 * mi + 2)]
        for comp in short_memory:
            k_short = comp.sum_covariance(np.arange(near.size + 2 * mi + 1, dtype=float), dt)
            c[: near.size] += _difference_covariance(k_short, near, mi)
        mu = slope * float(mi) * dt
        weight = (count - ell).astype(float)
        weight[1:] *= 2.0  # l and −l
        total = float(np.sum(weight * (2.0 * c**2 + 4.0 * mu * mu * c)))
        if count > ell.size and poles.size:
            linear, square = _tail_sums(weights, poles, mi, count, ell.size)
            total += 2.0 * (2.0 * square + 4.0 * mu * mu * linear)  # l and −l
        var = total / (4.0 * count * count)
        mean = 0.5 * (float(c[0]) + mu * mu)
        edf[i] = 2.0 * mean * mean / var if var > 0 else np.inf
    return edf


def _tail_sums(weights: np.ndarray, poles: np.ndarray, m: int, count: int, first: int) -> tuple[float, float]:
    """(Σ (M − l) c(l), Σ (M − l) c(l)²) over l = ``first`` … M − 1 (``first`` ≥ 2m, M = ``count``) for c(l) =
    Σ_j Re(Γ_j e^{w_j l'}), l' = l − 2m + 1, w_j = ``poles`` [per sample], Γ_j of :func:`model_av_edf`. With
    T(w) = Σ_{l'=a}^{J−1} (J − l') e^{l'w} = e^{aw} (J − a + g(J − a, w)), g of
    :func:`~..noise.sampled.lag_weighted_sum`, a the first l', J = M − 2m + 1: Σ (M − l) c(l) = Σ_j Re Γ_j T(w_j) and
    Σ (M − l) c(l)² = ½ Σ_jk Re[Γ_j Γ_k T(w_j + w_k) + Γ_j Γ̄_k T(w_j + w̄_k)]."""
    gamma = -weights * np.expm1(m * poles) ** 4 / (float(m) ** 2 * np.expm1(poles) ** 2)
    a = first - 2 * m + 1
    length = float(count - 2 * m + 1 - a)

    def t(w: np.ndarray) -> np.ndarray:
        return np.exp(a * w) * (length + lag_weighted_sum(np.array(length), w))

    linear = float(np.sum(np.real(gamma * t(poles))))
    same = gamma[:, None] * gamma[None, :] * t(poles[:, None] + poles[None, :])
    conjugate = gamma[:, None] * np.conj(gamma)[None, :] * t(poles[:, None] + np.conj(poles)[None, :])
    return linear, 0.5 * float(np.sum(np.real(same + conjugate)))


def _reach(c: Component, size: int, dt: float) -> int:
    """Lags after which ``c``'s K is linear (:data:`MEMORY_REACH` decay times), at most ``size``."""
    memory = c.memory(dt)[0]
    return min(size, math.ceil(MEMORY_REACH * memory / dt) + 2) if 0.0 < memory < math.inf else size


def _sum_covariance(c: Component, size: int, dt: float) -> np.ndarray:
    """K(0 … size − 1) of ``c``; of a scale-only component, its unit-scale K (cached) times the scale²."""
    split = c.scale_only()
    if split is None:
        return _computed_sum_covariance(c, size, dt)
    scale, fixed = split
    return scale**2 * _unit_sum_covariance(type(c), fixed, size, dt)


@functools.lru_cache(maxsize=4)
def _unit_sum_covariance(kind: type[Component], fixed: tuple[tuple[str, float], ...], size: int,
                         dt: float) -> np.ndarray:
    """K of the scale-only component ``kind`` at scale 1 with its ``fixed`` values (read-only, shared)."""
    k = _computed_sum_covariance(kind(**{kind.scale_name: 1.0}, **dict(fixed)), size, dt)
    k.flags.writeable = False
    return k


def _computed_sum_covariance(c: Component, size: int, dt: float) -> np.ndarray:
    """K(0 … size − 1) of ``c``, linear beyond :data:`MEMORY_REACH` decay times of a finite memory > 0."""
    reach = _reach(c, size, dt)
    if reach >= size:
        return _leading_sum_covariance(c, size, dt)
    k = np.empty(size)
    k[:reach] = _leading_sum_covariance(c, reach, dt)
    k[reach:] = k[reach - 1] + (k[reach - 1] - k[reach - 2]) * np.arange(1, size - reach + 1)
    return k


def _leading_sum_covariance(c: Component, size: int, dt: float) -> np.ndarray:
    """K(0 … size − 1) of ``c``: of complex exponential terms (a resonance's), −½ Σ_j S_j at consecutive lags
    (:func:`~..noise.sampled.consecutive_block_sum_variance`, products of exponentials in place of one per lag), else
    its :meth:`~..noise.base.Component.sum_covariance`."""
    terms = c.exponential_terms()
    if terms is None or not (np.any(np.imag(terms[0])) or np.any(np.imag(terms[1]))):
        return c.sum_covariance(np.arange(size, dtype=float), dt)
    return -0.5 * sum(consecutive_block_sum_variance(cj, sj, size, dt) for cj, sj in zip(*terms, strict=True))


def _difference_covariance(k: np.ndarray, ell: np.ndarray, m: int) -> np.ndarray:
    """c(l) at lags ``ell`` = 0, 1, … (an ``arange``) from ``k`` = K(0, 1, …) (even) for m-sample means."""
    size = ell.size
    head = min(size, 2 * m)
    c = np.empty(size)
    c[:head] = sum(v * _even_window(k, j * m, head) for v, j in zip(_V, range(-2, 3), strict=True))
    if size > head:
        c[head:] = sum(v * k[head + j * m: size + j * m] for v, j in zip(_V, range(-2, 3), strict=True))
    return c / float(m) ** 2


def _even_window(k: np.ndarray, shift: int, size: int) -> np.ndarray:
    """K(|l + shift|) for l = 0 … size − 1 from ``k`` = K(0, 1, …), K even: slices, no index array."""
    if shift >= 0:
        return k[shift: shift + size]
    back = min(size, -shift)  # l < −shift: K(−shift − l), descending
    window = np.empty(size)
    window[:back] = k[-shift - back + 1: -shift + 1][::-1]
    window[back:] = k[: size - back]
    return window


def model_av_band(av_data: np.ndarray, components: list[Component], m: np.ndarray, n: int, dt: float, *,
                  confidence: float = CONFIDENCE_95) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) ``confidence`` interval [u²] of ``av_data`` with :func:`model_av_edf`'s EDF (SP1065 eq. 45)."""
    edf = np.maximum(model_av_edf(components, m, n, dt), 1.0)
    return chi2_interval(np.asarray(av_data, dtype=float), edf, confidence)


@dataclass(frozen=True)
class ModelAvRange:
    """Where a record's overlapping AV falls with probability ``confidence`` if the model holds: at ``tau`` [s] the
    model's AV ``av`` [u²] and the range ``low`` … ``high`` [u²] (:func:`model_av_range`)."""

    tau: np.ndarray
    av: np.ndarray
    low: np.ndarray
    high: np.ndarray
    confidence: float


def model_av_range(components: list[Component], m: np.ndarray, n: int, dt: float, *,
                   confidence: float = CONFIDENCE_95) -> ModelAvRange:
    """The ``confidence`` range of the overlapping AV of ``n`` samples at ``dt`` [s] and factors ``m`` under the
    model ``components``: AV_hat ~ AV·χ²_ν/ν with ν :func:`model_av_edf`'s EDF (SP1065 eq. 45 read forwards), so
    low, high = AV·χ²_ν((1 ∓ c)/2)/ν. The closed form of the band paper 000 figs. 4, 6, 7 draw from simulations of
    the fitted model; why: docs/diagnostics.md, "Why the figures' model band is closed-form"."""
    m = np.asarray(m, dtype=np.int64)
    tau = m * dt
    av = total_allan_variance(components, tau, dt)
    edf = np.maximum(model_av_edf(components, m, n, dt), 1.0)
    low = av * stats.chi2.ppf(0.5 - confidence / 2.0, edf) / edf
    high = av * stats.chi2.ppf(0.5 + confidence / 2.0, edf) / edf
    return ModelAvRange(tau, av, low, high, confidence)
