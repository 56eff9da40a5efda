"""AVs of simulations of a fitted model: the band a record's AV falls in if the model holds (paper 000 figs. 4, 6,
7)."""

from __future__ import annotations

import numpy as np

from ..allan import choose_m
from ..allan.estimators import phase
from ..noise.components import Component, simulate_sum

#: At averaging factor m a simulation's AV sums every max(1, m // TERMS_PER_FACTOR)-th term of the overlapping sum.
TERMS_PER_FACTOR = 8


def thinned_allan_variance(y: np.ndarray, dt: float, m: np.ndarray) -> np.ndarray:
    """Overlapping AV [u²] of ``y`` [u] at ``dt`` [s] and factors ``m`` (paper 000 eq. 2) over every s-th start only,
    s = max(1, m // :data:`TERMS_PER_FACTOR`); why: docs/analysis.md, "Why simulations thin …"."""
    x = phase(np.asarray(y, dtype=float), dt)
    out = np.empty(np.asarray(m).size)
    buffer = np.empty(x.size)
    for k, factor in enumerate(np.asarray(m, dtype=np.int64)):
        f = int(factor)
        step = max(1, f // TERMS_PER_FACTOR)
        end = x.size - 2 * f
        d = buffer[: (end + step - 1) // step]
        np.multiply(x[f: f + end: step], -2.0, out=d)
        d += x[:end:step]
        d += x[2 * f: 2 * f + end: step]
        out[k] = float(np.einsum("i,i->", d, d)) / (2.0 * (f * dt) ** 2 * d.size)
    return out


def allan_band(components: list[Component], dt: float, n: int, tau: np.ndarray | None = None, *, n_sim: int = 20,
               seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(τ [s], AV [u²] (n_sim, len(τ))) of ``n_sim`` simulations of n samples at ``dt`` [s]; ``tau`` rounded to
    multiples of ``dt``, default the :func:`~..allan.choose_m` grid."""
    m = choose_m(n) if tau is None else np.unique(np.maximum(np.round(np.asarray(tau, float) / dt), 1))
    rng = np.random.default_rng(seed)
    rows = [thinned_allan_variance(simulate_sum(components, n, dt, rng), dt, m) for _ in range(n_sim)]
    return m * dt, np.array(rows)
