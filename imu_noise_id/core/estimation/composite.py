"""A likelihood of fixed size for long records: the banded Whittle likelihood above the block sums' band plus the
exact likelihood of the block sums.

Beyond the papers. The record's frequencies are split at the block sums' Nyquist frequency π/L [rad/sample] (L samples
per block, :mod:`.block_sums`): below it the exact Gaussian likelihood of the differences of the block sums (every
component through its sum covariance, the random walk, flicker noise and GMs of long τ told apart as by the full
likelihood), above it the Whittle likelihood of the tapered periodogram of the differences (:mod:`.whittle`), pooled in
log-spaced bands and kept single around the start's OSC lines:

    ℓ_c(θ) = −Σ_{b: ω_b > π/L} n_b [ln S_Δ(ω_b; θ) + Ī_b / S_Δ(ω_b; θ)] + ℓ_blocks(θ)

(S_Δ the exact spectrum of the sampled model's differences, Ī_b the band's mean periodogram). Each evaluation costs
O(bands + M³) whatever N; the statistics are computed once per record in one O(N log N) pass. Its maximiser starts the
exact likelihood's finish close to its maximum, and the closed loop searches on it (reasons and measurements:
docs/em.md, "Searching long records on a likelihood of fixed size").
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.optimize import minimize

from ..noise.components import RR, Component
from ..quality import interpolate_missing
from . import block_sums, whittle

if TYPE_CHECKING:
    from .model import NoiseModel
    from .results import FitResult

#: Records of this many samples or more are searched on ℓ_c (:func:`fit_model`): the model selection's candidates and
#: the closed loop's moves.
MIN_SAMPLES = 250_000


@dataclass(frozen=True)
class CompositeStatistics:
    """The record's tapered periodogram of differences and block sums (computed once), its period ``dt`` [s] and
    length ``n``."""

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

    def bands(self, start: list[Component]) -> whittle.BandedPeriodogram:
        """The Whittle part's bands above :attr:`split`, single around ``start``'s OSC lines
        (:func:`.whittle.line_windows`)."""
        bp = whittle.pooled(self.spectrum, fine=whittle.line_windows([start], self.dt))
        above = bp.omega > self.split
        return whittle.BandedPeriodogram(bp.omega[above], bp.count[above], bp.power[above])


def _whittle_part(components: list[Component], bp: whittle.BandedPeriodogram, dt: float) -> float:
    s = whittle.difference_spectrum(components, bp.omega, dt)
    if not np.all(s > 0):
        return -math.inf
    return -float(np.sum(bp.count * np.log(s) + bp.power / s))


def loglik(components: list[Component], stats: CompositeStatistics,
           bp: whittle.BandedPeriodogram | None = None) -> float:
    """ℓ_c of ``components`` (module docstring; up to a constant), on ``bp`` (default :meth:`CompositeStatistics.
    bands` of ``components``)."""
    bp = bp if bp is not None else stats.bands(components)
    return _whittle_part(components, bp, stats.dt) + block_sums.loglik(components, stats.sums)


def fit(start: list[Component], stats: CompositeStatistics,
        bounds: dict[str, tuple[float, float]]) -> tuple[float, list[Component]]:
    """Maximise ℓ_c over the log-parameters of ``start``'s stochastic components (RR held) within the physical
    ``bounds`` (:func:`.mle.physical_bounds`): climbed from ``start`` and from the banded Whittle likelihood's maximiser
    from it (:func:`.whittle.whittle_fit`, whose plain steps leave a start far from the maximum better than the
    whitened ones, which can cross into a lower mode), the better kept; (ℓ_c, fitted components)."""
    bp = whittle.pooled(stats.spectrum, fine=whittle.line_windows([start], stats.dt))
    climbs = [_climb(start, stats, bounds)]
    with contextlib.suppress(ValueError):  # the Whittle climb left the components' domain: the start's climb only
        moved = whittle.whittle_fit(start, np.empty(0), stats.dt, bp, bounds)[1]
        if not _same_point(moved, start):  # else its climb would repeat the start's
            climbs.append(_climb(moved, stats, bounds))
    return max(climbs, key=lambda c: c[0])


def fit_model(model: NoiseModel, starts: list[list[Component]], stats: CompositeStatistics) -> FitResult:
    """The fit of ``model`` at the maximiser of ℓ_c (:func:`fit`, from each of ``starts``, the best kept) on
    ``stats`` (the record's, or of the record with its regressors removed), evaluated once on the exact likelihood:
    its log-likelihood, BIC and innovations are exact at those values, the means GLS there; no EM or quasi-Newton step
    on the exact likelihood, no intervals. InputError (a ValueError) when no start can be evaluated."""
    from .model import FitOptions  # model imports the searches this module serves

    fits = [fit(start, stats, model.parameter_bounds) for start in starts]
    at_values = FitOptions(em_iter=0, polish=False, uncertainty=False, spectral_init=False)
    return model.fit(max(fits, key=lambda f: f[0])[1], at_values)


def _same_point(a: list[Component], b: list[Component], tol: float = 1e-3) -> bool:
    """Whether every parameter of ``a`` is within a relative ``tol`` of ``b``'s (same structure)."""
    return all(math.isclose(pa[k], pb[k], rel_tol=tol) for ca, cb in zip(a, b, strict=True)
               for pa, pb in [(ca.params(), cb.params())] for k in pa)


def _climb(start: list[Component], stats: CompositeStatistics,
           bounds: dict[str, tuple[float, float]]) -> tuple[float, list[Component]]:
    """ℓ_c climbed from ``start`` (:func:`fit`); ``start`` itself when no step gains. L-BFGS-B in η = Lᵀ(ϑ − ϑ₀),
    L Lᵀ the Whittle information at the start
    (:func:`.whittle.whittle_information`), a point outside the box scored at its projection plus a quadratic pull
    (as :func:`.mle.maximise`)."""
    bp = stats.bands(start)
    keys = [(i, k) for i, c in enumerate(start) if not isinstance(c, RR) for k in c.parameter_names]
    if not keys:
        return loglik(start, stats, bp), list(start)
    x0 = np.log([start[i].params()[k] for i, k in keys])
    lo = np.array([math.log(bounds[k][0]) if k in bounds else -np.inf for _, k in keys])
    hi = np.array([math.log(bounds[k][1]) if k in bounds else np.inf for _, k in keys])
    x0 = np.clip(x0, lo, hi)
    info = whittle.whittle_information(start, np.empty(0), stats.dt,
                                       whittle.pooled(stats.spectrum, fine=whittle.line_windows([start], stats.dt)))
    w, v = np.linalg.eigh(0.5 * (info + info.T))
    w = np.maximum(w, 1e-6 * max(float(np.max(w)), 1e-300))
    transform = v / np.sqrt(w)  # ϑ = ϑ₀ + T η  ⇒  Tᵀ info T = I

    def negll(eta: np.ndarray) -> float:
        raw = x0 + transform @ eta
        x = np.clip(raw, lo, hi)
        try:
            ll = loglik(whittle.with_log_parameters(start, keys, x), stats, bp)
        except ValueError:
            return 1e10
        return -ll + 0.5 * float((raw - x) @ (raw - x)) if math.isfinite(ll) else 1e10

    first = negll(np.zeros(x0.size))
    if first >= 1e10:
        return -math.inf, list(start)
    # searched relative to the start's value: L-BFGS-B's stopping rule is relative to |ℓ_c| (~N), not to its changes
    res = minimize(lambda eta: negll(eta) - first, np.zeros(x0.size), method="L-BFGS-B",
                   options={"maxiter": 500, "ftol": 1e-15, "gtol": 0.05, "eps": 1e-5})
    if res.fun >= 0.0:
        return -first, list(start)
    x = np.clip(x0 + transform @ res.x, lo, hi)
    return -float(first + res.fun), whittle.with_log_parameters(start, keys, x)
