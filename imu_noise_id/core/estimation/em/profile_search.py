"""The search along one parameter's profile likelihood (:mod:`.profile`): :func:`centre` finds its maximum from
points around the estimate and a parabola, :func:`end` each end of the 95 % interval on the signed root
r(v) = √(2(max ℓ_A − ℓ_A(v))): secant steps outward until r passes 1.96, then Illinois regula falsi to :data:`R_TOL`."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..readouts.quantiles import Z95

#: Each end is accepted when |r − Z95| is below this (an interval of 94.4–95.6 % nominal level).
R_TOL = 0.05
#: Profile evaluations per end at most (outward steps and regula falsi together).
MAX_POINTS = 12
#: Outward steps that raise the signed root by less than this (the profile is flat) jump to the end of the range.
FLAT_PROGRESS = 0.1
#: An outward step from a point whose signed root is this close below Z95 goes where the secant puts Z95 (it is then
#: accurate to a fraction of the gap); from further inside it goes at least 1.25× further, to bracket the end.
SECANT_TRUSTED = 0.25

#: One profile point: (distance from the centre, signed root r, argmax of the other parameters).
Point = tuple[float, float, np.ndarray]
#: ``profile_at(v, starts)`` → (ℓ_A(v), argmax) from the best of ``starts``.
ProfileAt = Callable[[float, list[np.ndarray]], tuple[float, np.ndarray]]


def _parabola_vertex(x: np.ndarray, a: np.ndarray) -> float:
    """The maximum's abscissa of the least-squares parabola through (x, a): NaN where it opens upwards or the points
    do not determine it (fewer than three distinct x to rounding, or x too small to square: the fit is made on x over
    its largest |x|, and its rank checked, so no conditioning warning reaches the console)."""
    scale = float(np.max(np.abs(x)))
    if not (math.isfinite(scale) and scale > 0.0):
        return math.nan
    u = x / scale
    (c2, c1, _), _, rank, _ = np.linalg.lstsq(np.column_stack([u * u, u, np.ones_like(u)]), a, rcond=None)
    return -c1 / (2.0 * c2) * scale if rank == 3 and c2 < 0 else math.nan


def centre(profile_at: ProfileAt, v_hat: float, a_hat: float, theta_hat: np.ndarray, steps: list[float], *,
           predict: Callable[[float], list[np.ndarray]], parabola: bool) -> list[tuple[float, float, np.ndarray]]:
    """Profile points (v, ℓ_A, argmax) at the estimate and at ``v_hat + step`` for each step (starts
    ``predict(step)``), plus, with ``parabola``, the vertex of the parabola through them when it lies inside."""
    pts = [(v_hat, a_hat, theta_hat)]
    for step in steps:
        a, th = profile_at(v_hat + step, predict(step))
        pts.append((v_hat + step, a, th))
    good = [p for p in pts if math.isfinite(p[1])]
    if parabola and len(good) >= 3:
        v = np.array([p[0] for p in good])
        vertex = _parabola_vertex(v - v_hat, np.array([p[1] for p in good]))
        if math.isfinite(vertex) and min(v - v_hat) < vertex < max(v - v_hat) and abs(vertex) > 0.05 * np.ptp(v):
            a, th = profile_at(v_hat + vertex, predict(vertex))
            pts.append((v_hat + vertex, a, th))
    return pts


def end(profile_at: ProfileAt, starts_near: Callable[[np.ndarray], list[np.ndarray]],
        pts_all: list[tuple[float, float, np.ndarray]], direction: float, *, first: float, limit: float) -> float:
    """End of the 95 % interval in ``direction`` (±1) from the best of ``pts_all`` (v, ℓ_A, argmax); ±inf when not
    reached within ``limit`` (distance). ``starts_near(θ)``: starts of a point whose argmax is predicted at θ;
    ``first``: the first distance tried when no known point lies that way."""
    v_c, a_max, th_c = max(pts_all, key=lambda p: p[1])

    def root(a: float) -> float:
        return math.sqrt(2.0 * max(a_max - a, 0.0)) if math.isfinite(a) else math.inf

    # ordered by (distance, root) alone: a tie would otherwise compare the argmax arrays
    known = sorted(((direction * (v - v_c), root(a), th) for v, a, th in pts_all if direction * (v - v_c) > 0),
                   key=lambda p: p[:2])
    pts: list[Point] = [(0.0, 0.0, th_c)] + [p for p in known if math.isfinite(p[1])]
    inside: list[float] = [0.0, -Z95]  # Illinois regula falsi on f = r − Z95: [distance, f] with f < 0 …
    outside: list[float] | None = None  # … and with f > 0 once bracketed
    for d, r, _ in known:
        if outside is None and abs(r - Z95) < R_TOL:  # a point already on the end, before any beyond it
            return v_c + direction * d
        if r < Z95:
            inside = [d, r - Z95]
        elif outside is None:
            outside = [d, min(r - Z95, 10.0 * Z95)]
    last_moved = 0  # which end the previous step replaced (−1 inside, +1 outside)
    d = min(max(first, 1e-12), limit) if len(pts) == 1 else None
    for _ in range(MAX_POINTS):
        if outside is None:  # still inside: step outward along the secant of r, 1.25–4× further
            if d is None:
                if inside[0] >= limit:
                    return direction * math.inf
                (d0, r0, _), (d1, r1, _) = pts[-2], pts[-1]
                if len(pts) >= 3 and r1 < r0 + FLAT_PROGRESS:  # a flat profile: try the end of the range
                    d = limit
                else:
                    grow = d0 + (Z95 - r0) * (d1 - d0) / (r1 - r0) if r1 > r0 else math.inf
                    least = d1 * (1.0 + 1e-3) if Z95 - r1 < SECANT_TRUSTED else 1.25 * d1
                    d = min(max(grow, least), 4.0 * d1, limit)
        else:
            if outside[0] - inside[0] < 1e-3 * outside[0]:
                break
            d = inside[0] - inside[1] * (outside[0] - inside[0]) / (outside[1] - inside[1])
        near = sorted(pts, key=lambda p: abs(p[0] - d))[:2]
        ll_a, th = profile_at(v_c + direction * d, starts_near(_extrapolate(near, d)))
        r = root(ll_a)
        if abs(r - Z95) < R_TOL:
            return v_c + direction * d
        if math.isfinite(r):
            pts.append((d, r, th))
            pts.sort(key=lambda p: p[0])
        f = min(r - Z95, 10.0 * Z95)  # an evaluation outside the domain counts as far outside
        if f < 0:
            inside = [d, f]
            if outside is not None and last_moved == -1:
                outside[1] *= 0.5
            last_moved = -1
        else:
            outside = [d, f]
            if last_moved == 1:
                inside[1] *= 0.5
            last_moved = 1
        d = None
    if outside is None:
        return direction * math.inf
    d = inside[0] - inside[1] * (outside[0] - inside[0]) / (outside[1] - inside[1])
    return v_c + direction * d


def _extrapolate(near: list[Point], d: float) -> np.ndarray:
    """Argmax at distance d by linear extrapolation (or interpolation) of two profile points."""
    if len(near) < 2 or near[1][0] == near[0][0]:
        return near[0][2].copy()
    (d0, _, t0), (d1, _, t1) = near
    w = min(max((d - d0) / (d1 - d0), -1.0), 2.0)
    return t0 + w * (t1 - t0)
