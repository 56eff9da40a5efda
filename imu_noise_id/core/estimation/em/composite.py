"""A likelihood of fixed size for long records (beyond the papers): the record's frequencies split at the block sums'
Nyquist frequency π/L [rad/sample], the exact likelihood of the block sums below (:mod:`.block_sums`), the banded
Whittle likelihood of the tapered differences above (:mod:`.whittle`, single around the start's OSC lines):

    ℓ_c(θ) = −Σ_{b: ω_b > π/L} n_b [ln S_Δ(ω_b; θ) + Ī_b / S_Δ(ω_b; θ)] + ℓ_blocks(θ),

S_Δ the sampled model's difference spectrum, Ī_b a band's mean periodogram; O(bands + M³) per evaluation."""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.optimize import minimize

from ...noise.components import RR, Component
from ...quality import interpolate_missing
from . import block_sums, exponential_parts, whittle

if TYPE_CHECKING:
    from .model import NoiseModel
    from .results import FitResult

#: Records of this many samples or more are searched on ℓ_c (:func:`fit_model`): the model selection's candidates and
#: the closed loop's moves.
MIN_SAMPLES = 250_000


@dataclass(frozen=True)
class CompositeStatistics:
    """The record's tapered periodogram of differences and block sums, its period ``dt`` [s] and length ``n``."""

    spectrum: whittle.TaperedPeriodogram
    sums: block_sums.BlockSums
    dt: float
    n: int

    @classmethod
    def of(cls, y: np.ndarray, dt: float) -> CompositeStatistics:
        """Both statistics of one axis ``y`` [u] at period ``dt`` [s] (NaN samples interpolated)."""
        filled = interpolate_missing(np.asarray(y, dtype=float))
        return cls(whittle.tapered_periodogram(filled), block_sums.block_sums(filled, dt), float(dt), int(filled.size))

    @property
    def split(self) -> float:
        """The block sums' Nyquist frequency π/L [rad/sample]: the Whittle part reads the bands above it."""
        return math.pi / self.sums.block

    def pooled(self, start: list[Component]) -> whittle.BandedPeriodogram:
        """The whole periodogram in bands, single around ``start``'s OSC lines (:func:`.whittle.pooled`)."""
        return whittle.pooled(self.spectrum, fine=whittle.line_windows([start], self.dt))

    def bands(self, start: list[Component],
              pooled: whittle.BandedPeriodogram | None = None) -> whittle.BandedPeriodogram:
        """The Whittle part's bands above :attr:`split`, single around ``start``'s OSC lines: those of ``pooled``
        (default: :meth:`pooled` of ``start``)."""
        bp = pooled if pooled is not None else self.pooled(start)
        above = bp.omega > self.split
        return whittle.BandedPeriodogram(bp.omega[above], bp.count[above], bp.power[above])


def loglik(components: list[Component], stats: CompositeStatistics,
           bp: whittle.BandedPeriodogram | None = None) -> float:
    """ℓ_c of ``components`` (up to a constant) on ``bp`` (default: :meth:`CompositeStatistics.bands`)."""
    bp = bp if bp is not None else stats.bands(components)
    return whittle.components_loglik(components, bp, stats.dt) + block_sums.loglik(components, stats.sums)


def fit(start: list[Component], stats: CompositeStatistics,
        bounds: dict[str, tuple[float, float]]) -> tuple[float, list[Component]]:
    """(ℓ_c, fitted components) maximised over the log-parameters (RR held) within ``bounds``, climbed from ``start``
    and from the banded Whittle maximiser from it, the better kept."""
    bp = stats.pooled(start)
    climbs = [_climb(start, stats, bounds, bp)]
    with contextlib.suppress(ValueError):  # the Whittle climb left the components' domain: the start's climb only
        moved = whittle.whittle_fit(start, np.empty(0), stats.dt, bp, bounds)[1]
        if not _same_point(moved, start):  # else its climb would repeat the start's
            climbs.append(_climb(moved, stats, bounds))
    return max(climbs, key=lambda c: c[0])


def fit_model(model: NoiseModel, starts: list[list[Component]], stats: CompositeStatistics) -> FitResult:
    """``model`` fitted at ℓ_c's maximiser (best of ``starts``) and scored once on the exact likelihood: exact ℓ, BIC
    and innovations at those values, GLS means, no intervals. InputError when no start can be evaluated."""
    from .model import FitOptions  # model imports the searches this module serves

    fits = [fit(start, stats, model.parameter_bounds) for start in starts]
    at_values = FitOptions(em_iter=0, polish=False, uncertainty=False, spectral_init=False)
    return model.fit(max(fits, key=lambda f: f[0])[1], at_values)


def _same_point(a: list[Component], b: list[Component], tol: float = 1e-3) -> bool:
    """Whether every parameter of ``a`` is within a relative ``tol`` of ``b``'s (same structure)."""
    return all(math.isclose(pa[k], pb[k], rel_tol=tol) for ca, cb in zip(a, b, strict=True)
               for pa, pb in [(ca.params(), cb.params())] for k in pa)


def _climb(start: list[Component], stats: CompositeStatistics, bounds: dict[str, tuple[float, float]],
           pooled: whittle.BandedPeriodogram | None = None) -> tuple[float, list[Component]]:
    """ℓ_c climbed from ``start`` (``start`` itself when no step gains): L-BFGS-B in η = Lᵀ(ϑ − ϑ₀), L Lᵀ the start's
    Whittle information, a point outside the box scored at its projection plus a quadratic pull; ``pooled``:
    :meth:`CompositeStatistics.pooled` of ``start`` where already computed."""
    pooled = pooled if pooled is not None else stats.pooled(start)
    bp = stats.bands(start, pooled)
    keys = [(i, k) for i, c in enumerate(start) if not isinstance(c, RR) for k in c.parameter_names]
    if not keys:
        return loglik(start, stats, bp), list(start)
    x0 = np.log([start[i].params()[k] for i, k in keys])
    lo = np.array([math.log(bounds[k][0]) if k in bounds else -np.inf for _, k in keys])
    hi = np.array([math.log(bounds[k][1]) if k in bounds else np.inf for _, k in keys])
    x0 = np.clip(x0, lo, hi)
    info = whittle.whittle_information(start, np.empty(0), stats.dt, pooled)
    w, v = np.linalg.eigh(0.5 * (info + info.T))
    w = np.maximum(w, 1e-6 * max(float(np.max(w)), 1e-300))
    transform = v / np.sqrt(w)  # ϑ = ϑ₀ + T η  ⇒  Tᵀ info T = I
    outside = (1e10, np.zeros(x0.size))
    parts = statistics_parts(stats, bp)

    def negll(eta: np.ndarray) -> tuple[float, np.ndarray]:
        raw = x0 + transform @ eta
        x = np.clip(raw, lo, hi)
        try:
            ll, grad = loglik_and_gradient(start, keys, x, stats, bp, parts=parts)
        except ValueError:
            return outside
        if not math.isfinite(ll):
            return outside
        pull = raw - x  # ∂x/∂raw is 0 where clipped, 1 inside
        return -ll + 0.5 * float(pull @ pull), transform.T @ (np.where(pull == 0.0, -grad, 0.0) + pull)

    first = negll(np.zeros(x0.size))[0]
    if first >= 1e10:
        return -math.inf, list(start)
    # searched relative to the start's value: L-BFGS-B's stopping rule is relative to |ℓ_c| (~N), not to its changes
    res = minimize(lambda eta: _shifted(negll(eta), first), np.zeros(x0.size), jac=True, method="L-BFGS-B",
                   options={"maxiter": 500, "ftol": 1e-15, "gtol": 0.05})
    if res.fun >= 0.0:
        return -first, list(start)
    x = np.clip(x0 + transform @ res.x, lo, hi)
    return -float(first + res.fun), whittle.with_log_parameters(start, keys, x)


def _shifted(value_gradient: tuple[float, np.ndarray], by: float) -> tuple[float, np.ndarray]:
    return value_gradient[0] - by, value_gradient[1]


def loglik_and_gradient(components: list[Component], keys: list[tuple[int, str]], x: np.ndarray,
                        stats: CompositeStatistics, bp: whittle.BandedPeriodogram, *,
                        parts: whittle.ComponentParts | None = None) -> tuple[float, np.ndarray]:
    """ℓ_c with the log-parameters ``keys`` set to ``x``, and its gradient in ``x``.

    By the chain rule through S_Δ = Σ_c S_c and γ_D = Σ_c γ_c (c the component of ϑ_j, Σ the block sums' Toeplitz
    covariance, T_h its lag-h basis matrix):

        ∂ℓ_c/∂ϑ_j = Σ_b n_b (Ī_b/S_Δ − 1)/S_Δ · ∂S_c/∂ϑ_j  +  ½ Σ_h tr[(Σ⁻¹DDᵀΣ⁻¹ − Σ⁻¹) T_h] ∂γ_c/∂ϑ_j,

    each component's (S_c, γ_c) stacked as its part (:meth:`.whittle.ComponentParts.gradient`; ``parts``: one per
    ``bp``, :func:`statistics_parts`). ValueError outside a domain; (−inf, zeros) where S_Δ ≤ 0 or Σ is not positive
    definite."""
    current = whittle.with_log_parameters(components, keys, x)
    parts = parts if parts is not None else statistics_parts(stats, bp)
    shares = parts.evaluate(current)
    total = shares.total
    s, gamma = total[: bp.omega.size], total[bp.omega.size:]
    if not np.all(s > 0):
        return -math.inf, np.zeros(x.size)
    whittle_ll = whittle.whittle_loglik(s, bp)
    blocks = block_sums.toeplitz_loglik_and_gradient(gamma, stats.sums.d)
    if blocks is None:
        return -math.inf, np.zeros(x.size)
    block_ll, d_gamma = blocks
    weights = np.concatenate([(bp.power / s - bp.count) / s, d_gamma])
    return whittle_ll + block_ll, parts.gradient(current, keys, x, shares, weights)


def statistics_parts(stats: CompositeStatistics, bp: whittle.BandedPeriodogram) -> whittle.ComponentParts:
    """Each component's share of ℓ_c's statistics: its difference spectrum on ``bp`` and its block sums'
    autocovariance, stacked; those with exponential terms with their closed-form shape derivatives
    (:func:`.exponential_parts.closed_parts`)."""
    lags = block_sums.sum_lags(stats.sums.block, stats.sums.d.size)

    factors = [lambda w: exponential_parts.difference_spectrum_factor(w, bp.omega),
               lambda w: exponential_parts.sum_covariance_factor(w, lags)]

    def combine(shares: list[np.ndarray]) -> np.ndarray:
        spectrum, sums = shares
        return np.concatenate([spectrum, block_sums.from_sum_covariance(sums)], axis=-1)

    def closed(components: list[Component]) -> exponential_parts.ClosedParts:
        return exponential_parts.closed_parts(components, stats.dt, factors, combine)

    return whittle.ComponentParts(lambda c: np.concatenate([
        whittle.difference_spectrum([c], bp.omega, stats.dt),
        block_sums.from_sum_covariance(c.sum_covariance(lags, stats.dt))]), closed)
