"""Theoretical WV of a component model and the covariance of the WV estimates across scales: ν²_j(θ) = AV(τ_j)/2 of the
sampled components (GMWM eq. 3's ν(θ)), and for a Gaussian model, K(u) the partial sums' generalised covariance
(:meth:`~..noise.base.Component.sum_covariance`),

    γ_ij(k) = Cov(W_{i,t}, W_{j,t+k}) = Σ_{a,b=0}^{2} c_a c_b K(k + a m_i − b m_j) / (4 m_i m_j),  c = (1, −2, 1),
    Cov(ν̂²_i, ν̂²_j) = 2 Σ_k n_ij(k) γ_ij(k)² / (M_i M_j)  (+ 4 μ_i μ_j Σ_k n_ij(k) γ_ij(k) / (M_i M_j) with a ramp)

(Serroukh, Walden & Percival 2000 for one level), n_ij(k) the pairs in the record, μ_j = ω·dt·m_j/2; robust WV: γ² →
ν_i²ν_j² Σ_k a_k² ρ^k/k! (ρ = γ/(ν_i ν_j)), × (2/e)². Lag sum: trapezoid, dense near γ's kinks, and at a sixteenth
to a thirty-second of each oscillating component's period (the next power of two over 32) within
:data:`TAIL_DECAY_TIMES` of its memory around each kink (a sensor's low-pass rings for a few samples, a narrow line
over the whole record), not at the shortest period over every lag; the pairs of scales in groups of at most
:data:`CHUNK_POINTS` lags, so that such a line's sum over every lag is held one group at a time."""

from __future__ import annotations

import itertools
import math
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from ..noise.components import RR, Component, total_allan_variance
from .robust import HERMITE_ORDERS, BiweightScale

#: The exponential tails of γ are followed for this many decay times.
TAIL_DECAY_TIMES = 20.0
#: Points per polynomial piece of γ at least; relative step of the geometric fans around each kink.
PIECE_POINTS, FAN_RATIO = 64, 0.125
#: Second difference of the phase (Haar filter on x).
_C = (1.0, -2.0, 1.0)


def theoretical_wv(components: list[Component], tau: np.ndarray, dt: float) -> np.ndarray:
    """ν²(τ) = AV(τ)/2 [u²] of the sum of ``components`` at scales ``tau`` [s] (exact for the sampled process)."""
    return 0.5 * total_allan_variance(list(components), np.asarray(tau, dtype=float), dt)


#: Per oscillating component, (lags its oscillation lasts, step that follows it) [samples].
Rings = tuple[tuple[int, float], ...]


def _offsets(length: int, cap: float, fine: float, rings: Rings = ()) -> np.ndarray:
    """Offsets 0..length from a kink: steps ``cap``, near the kink steps growing geometrically from max(1, fine/4),
    and within each ring's length of it that ring's step (an oscillation's, while it lasts)."""
    step = max(1, int(cap))
    # The first lags are always taken one by one: a component whose K jumps at u = 0 (QN, MA) puts an isolated value
    # at the kink itself, which must weigh one lag, not a whole step.
    parts = [np.arange(0, length + 1, step, dtype=np.int64), np.array([length], dtype=np.int64),
             np.arange(min(length, 3) + 1, dtype=np.int64)]
    parts += [np.arange(0, min(length, ring) + 1, max(1, int(ring_step)), dtype=np.int64)
              for ring, ring_step in rings if ring_step < cap]
    if math.isfinite(fine) and step > 1:
        first = max(1.0, fine / 4.0)
        n_geo = math.ceil(math.log(max(cap / first, 1.0)) / math.log1p(FAN_RATIO)) + 1
        d = np.cumsum(first * (1.0 + FAN_RATIO) ** np.arange(n_geo))
        parts.append(np.round(d[d < length]).astype(np.int64))
    return np.unique(np.concatenate(parts))


def _lag_grid(m_i: int, m_j: int, n: int, *, margin: int, fine: float, rings: Rings) -> tuple[np.ndarray, np.ndarray]:
    """Integer lags and trapezoid weights over [−2m_i − margin, 2m_j + margin] ∩ (−n, n): :data:`PIECE_POINTS` per
    piece between kinks, denser near each kink (``fine``, :func:`_offsets`) and within each of ``rings``."""
    lo, hi = max(-2 * m_i - margin, -(n - 1)), min(2 * m_j + margin, n - 1)
    kinks = {b * m_j - a * m_i for a in range(3) for b in range(3)}
    nodes = sorted({lo, hi, *(k for k in kinks if lo < k < hi)})
    parts = []
    for p, q in itertools.pairwise(nodes):
        length = q - p
        off = _offsets(length // 2 + 1, length / PIECE_POINTS, fine, rings)
        off = off[off <= length]
        parts += [p + off, q - off]
    k = np.unique(np.concatenate(parts)) if parts else np.array([lo], dtype=np.int64)
    w = np.empty(k.size)
    if k.size == 1:
        w[0] = 1.0
    else:
        gaps = np.diff(k).astype(float)
        w[0], w[-1] = 0.5 * gaps[0] + 0.5, 0.5 * gaps[-1] + 0.5
        w[1:-1] = 0.5 * (gaps[:-1] + gaps[1:])
    return k, w


def _pair_counts(k: np.ndarray, m_i: int, m_j: int, n: int) -> np.ndarray:
    """n_ij(k): pairs (s, s + k) with W_{i,s} and W_{j,s+k} inside the record."""
    top = np.minimum(n - 1, n - 1 - k)
    bottom = np.maximum(2 * m_i - 1, 2 * m_j - 1 - k)
    return np.maximum(top - bottom + 1, 0).astype(float)


#: Lags evaluated at once by :func:`wv_covariance` (pairs of scales grouped up to this many, one pair's at least): its
#: working memory is some ten to twenty float64 arrays of this size, not of the record's length times the pairs.
CHUNK_POINTS = 1 << 20


@dataclass(frozen=True)
class _Plan:
    """The lags of a group of pairs of scales, each pair's from ``starts``, with their trapezoid weights × pair counts
    and the pair's scales repeated per lag."""

    k: np.ndarray
    weight: np.ndarray
    m_i: np.ndarray
    m_j: np.ndarray
    starts: np.ndarray
    pairs: tuple[tuple[int, int], ...]


def _group(parts: list[tuple[np.ndarray, np.ndarray, int, int]], pairs: list[tuple[int, int]]) -> _Plan:
    sizes = np.array([p[0].size for p in parts])
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    k, w = np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
    m_i, m_j = (np.repeat([p[q] for p in parts], sizes) for q in (2, 3))
    return _Plan(k, w, m_i, m_j, starts, tuple(pairs))


def _plan_groups(m: tuple[int, ...], n: int, margin: int, fine: float, rings: Rings, *, limit: int):
    """The pairs' lag grids in groups of at most ``limit`` lags (one pair's at least), built as they are used."""
    parts: list[tuple[np.ndarray, np.ndarray, int, int]] = []
    pairs: list[tuple[int, int]] = []
    held = 0
    for i in range(len(m)):
        for j in range(i, len(m)):
            k, w = _lag_grid(m[i], m[j], n, margin=margin, fine=fine, rings=rings)
            if parts and held + k.size > limit:
                yield _group(parts, pairs)
                parts, pairs, held = [], [], 0
            parts.append((k, w * _pair_counts(k, m[i], m[j], n), m[i], m[j]))
            pairs.append((i, j))
            held += k.size
    yield _group(parts, pairs)


#: Lags of the plans kept between calls, in total (the fits evaluate the same plan again and again; the oldest go
#: first): 32 bytes each.
CACHE_POINTS = 1 << 23
_kept: OrderedDict[tuple, tuple[_Plan, ...]] = OrderedDict()
_too_large: set[tuple] = set()


def _plans(m: tuple[int, ...], n: int, margin: int, fine: float, rings: Rings):
    """The groups of pairs the lag sum runs over (at most :data:`CHUNK_POINTS` lags each): kept while all plans kept
    hold at most :data:`CACHE_POINTS` lags, else built as they are used (held one group at a time)."""
    key = (m, n, margin, fine, rings, CHUNK_POINTS)
    if key in _kept:
        _kept.move_to_end(key)
        return _kept[key]
    if (*key, CACHE_POINTS) in _too_large:
        return _plan_groups(m, n, margin, fine, rings, limit=CHUNK_POINTS)
    groups, held = [], 0
    for group in _plan_groups(m, n, margin, fine, rings, limit=CHUNK_POINTS):
        groups.append(group)
        held += group.k.size
        if held > CACHE_POINTS:  # too large to keep: built again group by group, now and on every later call
            _too_large.add((*key, CACHE_POINTS))
            return _plan_groups(m, n, margin, fine, rings, limit=CHUNK_POINTS)
    while _kept and held + sum(g.k.size for plan in _kept.values() for g in plan) > CACHE_POINTS:
        _kept.popitem(last=False)
    _kept[key] = tuple(groups)
    return _kept[key]


def _bucket(x: float) -> float:
    return 0.0 if x <= 0 else (math.inf if not math.isfinite(x) else 2.0 ** math.ceil(math.log2(x)))


def _ring(c: Component, n: int, dt: float) -> tuple[int, float] | None:
    """An oscillating component's ring: the lags [samples] its oscillation lasts (:data:`TAIL_DECAY_TIMES` of its
    memory, at most the record) and the step that follows it (the next power of two over its period, / 32); None for
    a component that does not oscillate."""
    longest, _, period = c.memory(dt)
    if not math.isfinite(period):
        return None
    return int(min(_bucket(TAIL_DECAY_TIMES * longest / dt), n)), _bucket(max(period / dt, 1.0)) / 32.0


#: Lags per kink an oscillation may add to each pair of scales (both sides of the kink) in a GMWM search: an OSC is
#: kept at least :func:`narrowest_line` wide, so that one covariance takes seconds, not minutes (docs/gmwm.md).
MAX_RING_LAGS = 1 << 14


def narrowest_line(frequency: float, n: int, dt: float) -> float:
    """The bandwidth [Hz] above which an OSC at ``frequency`` [Hz] rings over at most :data:`MAX_RING_LAGS` lags per
    kink on n samples at ``dt`` [s] (its memory 1/(πB) over :data:`TAIL_DECAY_TIMES`, the ring's length rounded up to
    a power of two at most doubles it); 0 when even the whole record is within it."""
    step = max(1, int(_bucket(max(1.0 / (frequency * dt), 1.0)) / 32.0))
    if 2 * n <= MAX_RING_LAGS * step:
        return 0.0
    return 4.0 * TAIL_DECAY_TIMES / (math.pi * dt * MAX_RING_LAGS * step)


def wv_covariance(components: list[Component], m: np.ndarray, n: int, dt: float, *,
                  scale: BiweightScale | None = None) -> np.ndarray:
    """(J, J) covariance [u⁴] of the WV estimates at ``m`` for n samples of the Gaussian model; ``scale``: of the
    robust WV."""
    m = np.asarray(m, dtype=np.int64)
    comps = list(components)
    stochastic = [c for c in comps if not isinstance(c, RR)]
    decay, fine, rings = 0.0, math.inf, set()
    for c in stochastic:
        longest, shortest, _ = c.memory(dt)
        if longest > 0:
            decay, fine = max(decay, longest / dt), min(fine, shortest / dt)
        ring = _ring(c, n, dt)
        if ring is not None:
            rings.add(ring)
    margin = int(min(_bucket(TAIL_DECAY_TIMES * decay), n))
    fine = _bucket(fine) / 2.0 if math.isfinite(fine) else math.inf
    nu2 = theoretical_wv(comps, m * dt, dt)
    slope = sum(abs(c.slope) for c in comps if isinstance(c, RR))
    n_coef = (n - 2 * m + 1).astype(float)
    out = np.empty((m.size, m.size))
    for plan in _plans(tuple(int(v) for v in m), int(n), margin, fine, tuple(sorted(rings))):
        i_idx = np.array([p[0] for p in plan.pairs])
        j_idx = np.array([p[1] for p in plan.pairs])
        sums = _lag_sums(plan, stochastic, dt, nu2[i_idx] * nu2[j_idx], scale=scale, slope=slope)
        out[i_idx, j_idx] = out[j_idx, i_idx] = sums / (n_coef[i_idx] * n_coef[j_idx])
    return out


def _lag_sums(plan: _Plan, stochastic: list[Component], dt: float, nu2_products: np.ndarray, *,
              scale: BiweightScale | None, slope: float) -> np.ndarray:
    """Σ_k n_ij(k) w_k f(γ_ij(k)) per pair of ``plan`` (module docstring: f = 2γ², the robust WV's Hermite series, the
    ramp's mean term); ``nu2_products``: ν_i² ν_j² per pair."""
    gamma = np.zeros(plan.k.size)
    for a in range(3):
        for b in range(3):
            u = plan.k + a * plan.m_i - b * plan.m_j
            gamma += _C[a] * _C[b] * np.sum([c.sum_covariance(u, dt) for c in stochastic], axis=0)
    gamma /= 4.0 * plan.m_i * plan.m_j
    if scale is None:
        terms = 2.0 * gamma**2
    else:
        nu_prod = np.repeat(np.sqrt(nu2_products), np.diff(np.append(plan.starts, plan.k.size)))
        rho = gamma / nu_prod
        terms = (4.0 / scale.e**2) * nu_prod**2 * sum(h * rho**order for h, order in
                                                      zip(scale.hermite, HERMITE_ORDERS, strict=True))
    if slope:
        mean = slope * dt * plan.m_i / 2.0, slope * dt * plan.m_j / 2.0
        terms = terms + 4.0 * mean[0] * mean[1] * gamma
    return np.add.reduceat(plan.weight * terms, plan.starts)
