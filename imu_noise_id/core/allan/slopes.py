"""Noise parameters read off an AV curve by its slopes (IEEE Std 952 annex C, Kalibr): QN μ = −2, 3Q²/τ², Q [u·s]; WN
−1, N²/τ, N [u/√Hz]; BI 0, (2 ln 2/π)·B², B [u]; RW +1, K²τ/3, K [u/s/√Hz]; RR +2, R²τ²/2, R [u/s]. Rules 1–5:
docs/analysis.md, "Noise parameters from the slopes"."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from ..errors import InputError
from ..noise.resonant import filter_memory_limit
from ..noise.units import random_walk_at_allan_variance
from .estimators import AllanResult

#: A component's region: where its line is at least this fraction of the fitted sum.
DOMINANCE = 0.5
#: Iterations of the reweighted linear least squares that gives the starting point.
IRLS_ITERATIONS = 3
_TINY = 1e-300
#: Huber threshold on standardised residuals: points beyond it are down-weighted (rule 1, outliers).
HUBER_K = 2.5
#: Rule 5: a local AV slope within this of white noise's −1 (or steeper) may end the low-pass roll-off ...
SLOPE_TOLERANCE = 0.1
#: ... when at least this many τ remain to read the lines from, and the slopes of this many steps from there on
#: are no steeper than −1 by more than the tolerance on average.
ROLLOFF_MIN_POINTS = 8
ROLLOFF_WHITE_STEPS = 3
#: The roll-off is the sensor filter's only if it ends within this many of the longest memory a sensor filter has
#: (:func:`~imu_noise_id.core.noise.resonant.filter_memory_limit`).
ROLLOFF_MAX_MEMORIES = 40
#: B = ADEV_min / BIAS_INSTABILITY_FACTOR (IEEE Std 952, flicker floor).
BIAS_INSTABILITY_FACTOR = math.sqrt(2.0 * math.log(2.0) / math.pi)


@dataclass(frozen=True)
class SlopeComponent:
    """One Allan-slope parameter of one axis: ``name`` (QN, WN, BI, RW, RR), ``slope`` μ in AV, ``coefficient`` c of
    c·τ^μ [u²·s^(−μ)], ``value`` (Q [u·s], N [u/√Hz], B [u], K [u/s/√Hz] or R [u/s]) with its ``ci`` ((0, value) for
    a bound), ``method`` ("fit" or "upper_bound"), ``tau_range`` [s], ``n_points``."""

    name: str
    slope: float
    coefficient: float
    value: float
    ci: tuple[float, float]
    method: str
    tau_range: tuple[float, float]
    n_points: int

    def line(self, tau: np.ndarray) -> np.ndarray:
        """The fitted AV line c·τ^μ at ``tau`` [s]."""
        return self.coefficient * np.asarray(tau, dtype=float) ** self.slope


@dataclass(frozen=True)
class AxisSlopes:
    """Slope parameters of one axis (QN, BI, RR None without a region), read from ``rolloff_tau`` [s] on."""

    noise_density: SlopeComponent
    random_walk: SlopeComponent
    quantization: SlopeComponent | None
    bias_instability: SlopeComponent | None
    rate_ramp: SlopeComponent | None
    rolloff_tau: float | None = None  # rule 5: the lines are read from this τ [s] on (None: the whole curve)

    def components(self) -> list[SlopeComponent]:
        """The reported components in order of slope, for plotting their lines."""
        return [
            c
            for c in (self.quantization, self.noise_density, self.bias_instability, self.random_walk, self.rate_ramp)
            if c is not None
        ]


# name: (μ, coefficient c → parameter value)
_LINES: dict[str, tuple[float, object]] = {
    "QN": (-2.0, lambda c: math.sqrt(c / 3.0)),
    "WN": (-1.0, math.sqrt),
    "BI": (0.0, lambda c: math.sqrt(c) / BIAS_INSTABILITY_FACTOR),
    "RW": (1.0, lambda c: random_walk_at_allan_variance(c, 1.0)),
    "RR": (2.0, lambda c: math.sqrt(2.0 * c)),
}


_NAMES = tuple(_LINES)
_MUS = np.array([mu for mu, _ in _LINES.values()])
#: The components always fitted (Kalibr's model); QN, BI and RR are added when significant.
BASE = ("WN", "RW")
EXTRAS = ("QN", "BI", "RR")
#: QN is tested where its line is at least this fraction of the sum.
QN_TEST_SHARE = 0.1
#: An extra line is also kept when the fit with it leaves the AV's intervals at this many τ fewer than WN + RW.
MENDED_MIN = 6


def fit_lines(tau: np.ndarray, variance: np.ndarray, edf: np.ndarray, names: tuple[str, ...] = _NAMES) -> np.ndarray:
    """c ≥ 0 (order QN, WN, BI, RW, RR; 0 outside ``names``) of AV ≈ Σ c_j τ^μ_j on one axis (rule 1)."""
    use = np.array([n in names for n in _NAMES])
    basis = tau[:, None] ** _MUS[None, use]
    ok = np.isfinite(variance) & (variance > 0) & (edf > 0)
    if ok.sum() < 3:
        raise InputError(
            f"only {ok.sum()} of {tau.size} Allan variances are positive: the signal is (nearly) constant, "
            "so no noise parameters can be read from it"
        )
    basis, av, nu = basis[ok], variance[ok], edf[ok]
    # Start: linear non-negative least squares, weights EDF/(2·model²), model refined a few times.
    model = av.copy()
    start = np.zeros(int(use.sum()))
    for _ in range(IRLS_ITERATIONS):
        w = np.sqrt(nu / 2.0) / model
        a = basis * w[:, None]
        col = np.linalg.norm(a, axis=0)
        col[col == 0] = 1.0
        start, _ = optimize.nnls(a / col, av * w)
        start = start / col
        model = np.maximum(basis @ start, _TINY)
    # Final: log-space residuals √(ν/2)·log(model/AV) (symmetric for high and low points) with a Huber loss.
    scale = np.median(av[:, None] / basis, axis=0)
    sigma = np.sqrt(nu / 2.0)
    log_av = np.log(av)

    def residuals(x: np.ndarray) -> np.ndarray:
        return sigma * (np.log(np.maximum(basis @ (x * scale), _TINY)) - log_av)

    x0 = np.maximum(start / scale, 1e-6)
    fit = optimize.least_squares(residuals, x0, bounds=(0.0, np.inf), loss="huber", f_scale=HUBER_K)
    coef = np.zeros(_MUS.size)
    coef[use] = fit.x * scale
    return coef


def _lines(coef: np.ndarray, tau: np.ndarray) -> np.ndarray:
    return coef[None, :] * tau[:, None] ** _MUS[None, :]


def _region(j: int, coef: np.ndarray, tau: np.ndarray, share: float = DOMINANCE) -> np.ndarray:
    """Indices of τ where line j is at least ``share`` (default :data:`DOMINANCE`) of the fitted sum (rule 2)."""
    lines = _lines(coef, tau)
    return np.flatnonzero((lines[:, j] > 0) & (lines[:, j] >= share * lines.sum(axis=1)))


def select_lines(res: AllanResult, axis: int) -> np.ndarray:
    """Coefficients of WN, RW and the extras (QN, BI, RR) with a region of ≥ 2 τ that the AV needs (rule 1)."""
    tau, av, edf = res.tau, res.variance[:, axis], res.edf[:, axis]
    lo, hi = res.ci_low[:, axis], res.ci_high[:, axis]
    base = fit_lines(tau, av, edf, BASE)
    base_model = _lines(base, tau).sum(axis=1)

    def misfits(model: np.ndarray) -> int:
        return int(np.sum((lo > model) | (hi < model)))

    keep = list(BASE)
    for extra in EXTRAS:
        coef = fit_lines(tau, av, edf, (*BASE, extra))
        region = _region(_NAMES.index(extra), coef, tau, QN_TEST_SHARE if extra == "QN" else DOMINANCE)
        above = np.sum(lo[region] > base_model[region]) >= 2
        mended = misfits(base_model) - misfits(_lines(coef, tau).sum(axis=1)) >= MENDED_MIN
        if region.size >= 2 and (above or mended):
            keep.append(extra)
    return base if len(keep) == len(BASE) else fit_lines(tau, av, edf, tuple(keep))


def _component(name: str, coef: np.ndarray, region: np.ndarray, res: AllanResult, axis: int) -> SlopeComponent:
    j = _NAMES.index(name)
    mu, to_value = _LINES[name]
    coefficient = float(coef[j])
    value = to_value(coefficient)
    lines = _lines(coef, res.tau[region])
    share = lines[:, j] / lines.sum(axis=1)
    nu = res.edf[region, axis]
    k = int(np.argmax(nu * share**2))  # the point with the most information on c (rule 3)
    i = region[k]
    av = res.variance[i, axis]
    c_lo = max(1.0 + (res.ci_low[i, axis] / av - 1.0) / share[k], 0.0)
    c_hi = 1.0 + (res.ci_high[i, axis] / av - 1.0) / share[k]
    # widened by the misfit of that point's own coefficient, in log, in quadrature (rule 3)
    others = lines[k].sum() - lines[k, j]
    own = (av - others) / res.tau[i] ** mu
    if own > 0 and c_lo > 0 and not c_lo <= coefficient / own <= c_hi:
        d2 = math.log(own / coefficient) ** 2
        c_lo = math.exp(-math.sqrt(math.log(c_lo) ** 2 + d2))
        c_hi = math.exp(math.sqrt(math.log(c_hi) ** 2 + d2))
    tau = res.tau
    return SlopeComponent(name, mu, coefficient, value, (value * math.sqrt(c_lo), value * math.sqrt(c_hi)), "fit",
                          (float(tau[region[0]]), float(tau[region[-1]])), int(region.size))


def _upper_bound(name: str, res: AllanResult, axis: int) -> SlopeComponent:
    mu, to_value = _LINES[name]
    bounds = res.ci_high[:, axis] / res.tau**mu  # c ≤ AV_hi(τ)/τ^μ at every τ (rule 4)
    i = int(np.argmin(bounds))
    coefficient = float(bounds[i])
    value = to_value(coefficient)
    t = float(res.tau[i])
    return SlopeComponent(name, mu, coefficient, value, (0.0, value), "upper_bound", (t, t), 1)


def _rolloff_candidate(tau: np.ndarray, av: np.ndarray, dt: float, *, white_after: bool = True) -> int:
    """Where a start flatter than white noise ends in its −1 slope (rule 5 and its constants), 0 if nowhere; without
    ``white_after``, the slopes after that end need not average −1 (a hump's slow descent into the white line)."""
    ok = np.isfinite(av) & (av > 0)
    # the curve's minimum beyond its first peak (a strong low-pass can put the global minimum at the shortest τ)
    early = np.flatnonzero(ok & (tau <= ROLLOFF_MAX_MEMORIES * filter_memory_limit(dt)))
    peak = int(early[np.argmax(av[early])]) if early.size else 0
    stop = peak + int(np.argmin(np.where(ok, av, np.inf)[peak:]))
    if stop < 2 or not ok[: stop + 1].all():
        return 0
    slope = np.diff(np.log(av[: stop + 1])) / np.diff(np.log(tau[: stop + 1]))
    flatter = np.flatnonzero(slope > -1.0 + 2.0 * SLOPE_TOLERANCE)
    ends = np.flatnonzero(slope[flatter[0]:] <= -1.0 + SLOPE_TOLERANCE) + flatter[0] if flatter.size else flatter
    if not ends.size:
        return 0
    j = int(ends[0])
    fits = tau.size - j >= ROLLOFF_MIN_POINTS and tau[j] <= ROLLOFF_MAX_MEMORIES * filter_memory_limit(dt)
    white = not white_after or float(np.mean(slope[j: j + ROLLOFF_WHITE_STEPS])) >= -1.0 - SLOPE_TOLERANCE
    return j if fits and white else 0


def rolloff_end(res: AllanResult, axis: int = 0) -> int:
    """First τ index beyond the sensor's low-pass roll-off (rule 5), 0 if none; where the AV rises within the τ a
    roll-off reaches (:func:`rises_early`), the end of the hump's descent to the −1 slope, however it continues."""
    j = _rolloff_candidate(res.tau, res.variance[:, axis], res.dt, white_after=not rises_early(res, axis))
    if not j:
        return 0
    rest = res.from_index(j)
    base = fit_lines(rest.tau, rest.variance[:, axis], rest.edf[:, axis], BASE)
    region = _region(_NAMES.index("WN"), base, rest.tau)
    if not region.size:
        return 0
    n_low = _component("WN", base, region, rest, axis).ci[0]
    return j if res.ci_high[0, axis] < n_low**2 / res.tau[0] else 0


def rises_early(res: AllanResult, axis: int = 0) -> bool:
    """Whether the AV rises significantly within the τ a sensor filter's roll-off reaches (τ ≤
    :data:`ROLLOFF_MAX_MEMORIES` · ``filter_memory_limit(dt)``): some τ_a < τ_b there with the lower bound at τ_b above
    the upper bound at τ_a. White noise, quantisation and flicker never rise; a filtered white noise beside a white
    floor after the filter does (its roll-off a hump over the floor's −1 line, which rule 5 may not read)."""
    early = np.flatnonzero(res.tau <= ROLLOFF_MAX_MEMORIES * filter_memory_limit(res.dt))
    low, high = res.ci_low[early, axis], res.ci_high[early, axis]
    ok = np.isfinite(low) & np.isfinite(high)
    if ok.sum() < 2:
        return False
    low, high = low[ok], high[ok]
    return bool(np.any(low[1:] > np.minimum.accumulate(high)[:-1]))


def fit_axis_slopes(res: AllanResult, axis: int = 0) -> AxisSlopes:
    """Allan-slope parameters of column ``axis`` (rules 1–5); ValueError if ``res`` is not an Allan variance."""
    if res.kind != "allan":
        raise ValueError(f"slope parameters are defined on the Allan variance, got a {res.kind} variance")
    start = rolloff_end(res, axis)
    if start:
        res = res.from_index(start)
    coef = select_lines(res, axis)
    found: dict[str, SlopeComponent | None] = {}
    for j, name in enumerate(_NAMES):
        region = _region(j, coef, res.tau)
        if region.size >= 2 or (name in ("WN", "RW") and region.size >= 1):
            found[name] = _component(name, coef, region, res, axis)
        elif name in ("WN", "RW"):
            found[name] = _upper_bound(name, res, axis)
        else:
            found[name] = None
    return AxisSlopes(
        noise_density=found["WN"], random_walk=found["RW"], quantization=found["QN"],
        bias_instability=found["BI"], rate_ramp=found["RR"], rolloff_tau=float(res.tau[0]) if start else None,
    )


def fit_slopes(res: AllanResult) -> list[AxisSlopes]:
    """:func:`fit_axis_slopes` for every column of ``res``."""
    return [fit_axis_slopes(res, j) for j in range(res.variance.shape[1])]
