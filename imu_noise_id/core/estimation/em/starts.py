"""Initial values from the Allan variance (paper 000 §3.5(i); beyond it): the structure's theoretical AV fitted to
the empirical one (τ ≤ N·dt/4) by least squares in log space, weighted by √(N/m), from several GM τ placements; the
distinct solutions, best first, are the multi-start values."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import least_squares

from ...allan import AllanResult, allan_variance
from ...errors import InputError
from ...noise import units
from ...noise.components import BI, DLPF, GM, LPF, MA, OSC, QN, RR, RW, WN, Component, total_allan_variance
from ...noise.digital import ORDERS as DLPF_ORDERS
from ...noise.digital import SensorFilter
from ...noise.flicker import PLATEAU, band_for_record
from ...noise.modelspec import canonical

#: The starting-value fit uses the AV at averaging factors m ≤ this fraction of the record.
MAX_FRACTION = 0.25


@dataclass(frozen=True)
class _Curve:
    """The part of one axis's Allan variance the starting values are fitted to: τ [s], AV [u²], clusters N/m."""

    tau: np.ndarray
    avar: np.ndarray
    n_clusters: np.ndarray
    n: int

    @classmethod
    def of(cls, allan: AllanResult, max_fraction: float = MAX_FRACTION) -> _Curve:
        """The first column of ``allan`` at m ≤ ``max_fraction``·N (at least the three shortest τ)."""
        keep = allan.m <= max(max_fraction * allan.n, allan.m[min(2, allan.m.size - 1)])
        return cls(allan.tau[keep], allan.variance[keep, 0], allan.n / allan.m[keep], int(allan.n))


def allan_of(y: np.ndarray, dt: float) -> AllanResult:
    """AV of a gap-filled record on the analysis grid."""
    return allan_variance(np.asarray(y, dtype=float), dt)


def _guess(names: list[str], av: _Curve, gm_taus: list[float], osc_frequencies: list[float],
           dt: float) -> list[Component]:
    tau, a = av.tau, av.avar
    t0, a0 = tau[0], a[0]
    t_end, a_end = tau[-1], a[-1]
    comps: list[Component] = []
    gm_iter = iter(gm_taus)
    osc_iter = iter(osc_frequencies)
    n_gm = names.count("GM")
    white = math.sqrt(a0 * t0)
    for name in names:
        if name == "WN":
            comps.append(WN(white * (0.3 if {"LPF", "DLPF", "MA"} & set(names) else 0.8)))
        elif name == "LPF":
            comps.append(LPF(white, 1.0 / (2.0 * math.pi * 2.0 * dt)))
        elif name == "MA":
            comps.append(MA(white))
        elif name == "DLPF":
            comps.append(DLPF(white, 0.25 / dt))
        elif name == "OSC":
            f0 = next(osc_iter, 0.25 / dt)
            level = float(np.interp(math.log(min(max(0.37 / f0, t0), t_end)), np.log(tau), a))
            comps.append(OSC(f0, max(0.05 * f0, 4.0 / (av.tau[-1] * 4.0)), math.sqrt(level)))
        elif name == "QN":
            comps.append(QN(math.sqrt(a0 / 3.0) * t0 * 0.5))
        elif name == "RW":
            comps.append(RW(units.random_walk_at_allan_variance(a_end, t_end) * 0.5))
        elif name == "GM":
            tc = next(gm_iter)
            level = float(np.interp(math.log(min(max(1.9 * tc, t0), t_end)), np.log(tau), a))
            comps.append(GM(tau=tc, sigma=math.sqrt(level / 0.38) / max(n_gm, 1)))
        elif name == "BI":
            # The flicker plateau a little below the AV's minimum, over the band the record supports.
            comps.append(BI(math.sqrt(0.5 * float(np.min(a)) / PLATEAU), *band_for_record(av.n, dt)))
        elif name == "RR":
            comps.append(RR(0.0))
        else:
            raise InputError(f"no Allan-variance initial value for component {name}")
    return comps


def _gm_placements(n_gm: int, t_lo: float, t_hi: float, n_grid: int) -> list[list[float]]:
    if n_gm == 0:
        return [[]]
    grid = np.exp(np.linspace(math.log(t_lo), math.log(t_hi), n_grid))
    if n_gm == 1:
        return [[float(t)] for t in grid]
    out = []
    for i in range(n_grid):
        for j in range(i + 1, n_grid):
            rest = list(np.exp(np.linspace(math.log(grid[j]), math.log(t_hi), n_gm - 1)))
            out.append([float(grid[i]), *map(float, rest)])
    return out


#: Parameters the AV fit holds at their starting values.
_HELD = {("OSC", "frequency"), ("OSC", "bandwidth")}
#: Relative AV below which a component's amplitude is at its ~0 boundary in :func:`fit_allan`.
AV_FLOOR = 1e-10


#: Parameters that shape a component's AV rather than scale it (differentiated numerically, in log).
_SHAPE = ("tau", "cutoff")
#: The log step of that numerical derivative.
_SHAPE_STEP = 1e-6


class _LogAvCurve:
    """Weighted log-AV misfit r(x) = (ln Σ_c AV_c(τ) − ln AV_hat(τ))·√(N/m) in the parameters' logs, and its Jacobian
    (2·AV_c/Σ AV·√(N/m) for amplitudes, a forward difference of the own AV for :data:`_SHAPE` ones)."""

    def __init__(self, start: list[Component], keys: list[tuple[int, str]], av: _Curve, dt: float) -> None:
        self.start, self.keys, self.av, self.dt = start, keys, av, dt
        self.base = [c.params() for c in start]  # once per placement, not per residual (asdict is slow)
        self.weight = np.sqrt(av.n_clusters)
        self._x: np.ndarray | None = None
        self._parts: dict[int, np.ndarray] = {}

    def build(self, x: np.ndarray) -> list[Component]:
        params = [dict(b) for b in self.base]
        for (i, k), v in zip(self.keys, x, strict=True):
            params[i][k] = float(np.exp(v))
        return [type(c)(**p) for c, p in zip(self.start, params, strict=True)]

    def _evaluate(self, x: np.ndarray) -> tuple[list[Component], dict[int, np.ndarray], np.ndarray]:
        comps = self.build(x)
        if self._x is None or not np.array_equal(x, self._x):
            self._parts = {i: c.allan_variance(self.av.tau, self.dt) for i, c in enumerate(comps)
                           if not isinstance(c, RR)}
            self._x = np.array(x, copy=True)
        return comps, self._parts, np.maximum(sum(self._parts.values()), 1e-300)

    def residuals(self, x: np.ndarray) -> np.ndarray:
        _, _, total = self._evaluate(x)
        return (np.log(total) - np.log(self.av.avar)) * self.weight

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        comps, parts, total = self._evaluate(x)
        jac = np.empty((self.av.tau.size, len(self.keys)))
        for k, (i, name) in enumerate(self.keys):
            if name in _SHAPE:
                params = comps[i].params() | {name: float(np.exp(x[k] + _SHAPE_STEP))}
                moved = type(comps[i])(**params).allan_variance(self.av.tau, self.dt)
                jac[:, k] = np.log(np.maximum(total - parts[i] + moved, 1e-300) / total) / _SHAPE_STEP
            else:
                jac[:, k] = 2.0 * parts[i] / total
        return jac * self.weight[:, None]


def fit_allan(names: list[str], allan: AllanResult, dt: float, n_grid: int = 4,
              osc_frequencies: list[float] | None = None) -> list[tuple[float, list[Component]]]:
    """(cost, components) of least-squares fits of the structure's AV to ``allan`` (one column) in log space, best
    first; RR at slope 0 (the caller detrends); OSC frequency (``osc_frequencies``, else fs/4) and bandwidth held."""
    av = _Curve.of(allan)
    fit_idx = [i for i, n in enumerate(names) if n != "RR"]
    t_lo = max(3.0 * dt, av.tau[0])
    t_hi = max(av.tau[-1] / 2.0, t_lo * 2.0)
    results: list[tuple[float, list[Component]]] = []
    for taus in _gm_placements(names.count("GM"), t_lo, t_hi, n_grid):
        start = _guess(names, av, taus, list(osc_frequencies or []), dt)
        keys = [(i, k) for i in fit_idx for k in start[i].parameter_names if (names[i], k) not in _HELD]
        x0 = np.log([start[i].params()[k] for i, k in keys])

        curve = _LogAvCurve(start, keys, av, dt)
        lo, hi = x0 - 25.0, x0 + 25.0
        for k, (i, name) in enumerate(keys):
            if name == "tau":
                lo[k], hi[k] = math.log(dt), math.log(50.0 * av.tau[-1])
            elif name == "cutoff":
                lo[k], hi[k] = math.log(0.2 / (av.tau[-1])), math.log(0.5 / dt)
            else:
                # explicit ~0 boundary: AV ∝ amplitude², at most AV_FLOOR of the data's (docs/em.md, "Why: starts")
                with np.errstate(divide="ignore"):
                    ratio = float(np.min(av.avar / start[i].allan_variance(av.tau, dt)))
                if math.isfinite(ratio) and ratio > 0:
                    lo[k] = max(lo[k], x0[k] + 0.5 * math.log(AV_FLOOR * ratio))
        x0 = np.clip(x0, lo + 1e-9, hi - 1e-9)
        try:
            sol = least_squares(curve.residuals, x0, jac=curve.jacobian, bounds=(lo, hi), method="trf",
                                max_nfev=200)
        except (ValueError, FloatingPointError):
            continue
        results.append((float(sol.cost), curve.build(sol.x)))
    if not results:
        raise InputError("the Allan-variance fit for initial values failed; give initial values (init=…)")
    results.sort(key=lambda r: r[0])
    return distinct(results, av.tau, dt)


#: A white noise beside a DLPF starts at least at this fraction of the DLPF's passband density.
DLPF_FLOOR_START = 0.1


def filter_orders(components: list[Component], known: SensorFilter | None = None) -> list[list[Component]]:
    """``components`` with each DLPF at every order of ``ORDERS`` (density and cutoff kept), one list per
    combination, each white noise beside it at ≥ :data:`DLPF_FLOOR_START` of its density; ``known`` (the user's
    filter) sets the cutoff and, when given, the only order. The starts' Whittle fits choose (docs/em.md, "Why:
    starts")."""
    dlpfs = [c for c in components if isinstance(c, DLPF)]
    if not dlpfs:
        return [list(components)]
    floor = DLPF_FLOOR_START * max(c.noise_density for c in dlpfs)
    out = [[replace(c, noise_density=max(c.noise_density, floor)) if isinstance(c, WN) else c for c in components]]
    orders = DLPF_ORDERS if known is None else known.orders
    for i, c in enumerate(components):
        if isinstance(c, DLPF):
            start = c if known is None else replace(c, cutoff=known.cutoff)
            out = [[*v[:i], replace(start, order=order), *v[i + 1:]] for v in out for order in orders]
    return out


def distinct(results: list[tuple[float, list[Component]]], tau: np.ndarray, dt: float,
             rel: float = 0.1) -> list[tuple[float, list[Component]]]:
    """``results`` without those whose theoretical AV is within ``rel`` of a better one's at every τ and whose DLPFs
    have the same orders: filters of different orders, which the AV barely tells apart (their roll-offs differ above
    the cutoff), stay for the exact likelihood to choose between."""
    kept: list[tuple[float, list[Component]]] = []
    curves: list[tuple[tuple[int, ...], np.ndarray]] = []
    for cost, comps in results:
        orders = tuple(int(c.order) for c in comps if isinstance(c, DLPF))
        curve = np.log(total_allan_variance([c for c in comps if not isinstance(c, RR)], tau, dt))
        if all(o != orders or np.max(np.abs(curve - other)) > math.log1p(rel) for o, other in curves):
            kept.append((cost, comps))
            curves.append((orders, curve))
    return kept


#: The GM a walk is split into starts at this fraction of the record's span.
SPLIT_GM_SPAN_FRACTION = 0.1
#: The walk left beside it starts at this fraction of the walk's K.
SPLIT_WALK_SHARE = 0.1


def walk_split(components: list[Component], span_s: float) -> list[Component] | None:
    """``components`` (a fit with one RW) with its walk K split into a GM of τ = :data:`SPLIT_GM_SPAN_FRACTION` ×
    ``span_s`` [s] whose spectrum above its corner is the walk's (σ = K·√(τ/2): K² = 2σ²/τ) and an RW of
    :data:`SPLIT_WALK_SHARE` × K, in canonical order; None without exactly one RW. The start of the same structure
    with a GM beside the walk, from the fit without it, in the slow mode the AV-fit starts miss beside a DLPF: there
    the AV fit spends the GM on the filter's roll-off, and the likelihood climbs from it to a GM of a few
    milliseconds (docs/em.md, "Why: starts")."""
    walks = [c for c in components if isinstance(c, RW)]
    if len(walks) != 1 or walks[0].random_walk <= 0.0:
        return None
    k = walks[0].random_walk
    tau = SPLIT_GM_SPAN_FRACTION * span_s
    rest = [c for c in components if not isinstance(c, RW)]
    return canonical([*rest, GM(tau=tau, sigma=k * math.sqrt(tau / 2.0)), RW(SPLIT_WALK_SHARE * k)])
