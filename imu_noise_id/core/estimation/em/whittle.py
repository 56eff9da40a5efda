"""Whittle (frequency-domain) likelihood of the differenced signal, for starting values and metrics (beyond paper 000,
§3.5(i)). Δy_t = y_t − y_{t−1} is stationary with two-sided spectral density per sample, at ω = 2πf·dt [rad/sample] and
c(ω) = 2 − 2cos ω:

    WN  σ²_WN·c(ω)      RW  σ²_RW      QN  σ²_QN·c(ω)²      GM  σ²_drive·c(ω) / (1 − 2φ cos ω + φ²)

Whittle's log-likelihood −Σ_j [log S(ω_j) + I(ω_j)/S(ω_j)] over the Fourier frequencies, the Hann-tapered periodogram
pooled in log-spaced bands: O(bands) per evaluation."""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize

from ...errors import InputError
from ...noise.components import GM, QN, RR, RW, WN, Component
from ...noise.digital import DLPF
from . import exponential_parts
from .differences import derivative_in_domain


@dataclass(frozen=True)
class BandedPeriodogram:
    """Periodogram of Δy in bands: centre ω [rad/sample], Fourier frequencies per band, summed periodogram."""

    omega: np.ndarray
    count: np.ndarray
    power: np.ndarray


@dataclass(frozen=True)
class TaperedPeriodogram:
    """Periodogram of Δy at every Fourier frequency ω_j = 2πj/M, j = 1…⌊(M−1)/2⌋ [rad/sample] (M differences)."""

    omega: np.ndarray
    power: np.ndarray
    m: int

    @functools.cached_property
    def cumulative(self) -> tuple[np.ndarray, np.ndarray]:
        """(Σ_{i<j} power_i, Σ_{i<j} ω_i) for j = 0 … len: any band's sums by two lookups (:func:`pooled`), once."""
        return (np.concatenate([[0.0], np.cumsum(self.power)]), np.concatenate([[0.0], np.cumsum(self.omega)]))


def tapered_periodogram(y: np.ndarray) -> TaperedPeriodogram:
    """I(ω_j) = |Σ_t w_t Δy_t e^{−iω_j t}|²/Σ_t w_t² of the demeaned differences of ``y`` (w: the Hann taper)."""
    d = np.diff(np.asarray(y, dtype=float))
    d = d - d.mean()
    m = d.size
    jmax = (m - 1) // 2
    if jmax < 8:
        raise InputError("too few samples for a spectral initial value")
    taper = np.hanning(m)
    spec = np.fft.rfft(d * taper)
    per = (spec[1: jmax + 1].real ** 2 + spec[1: jmax + 1].imag ** 2) / float(taper @ taper)
    return TaperedPeriodogram(2.0 * math.pi * np.arange(1, jmax + 1) / m, per, m)


@dataclass(frozen=True)
class LineWindow:
    """Where :func:`pooled` follows a line's shape: ``lo``, ``hi``, ``centre``, ``bandwidth`` [rad/sample]."""

    lo: float
    hi: float
    centre: float
    bandwidth: float


#: Inside a line's window a band spans at most this share of its distance from the line's centre, or of the line's
#: bandwidth nearer the centre (at least one frequency): the log-spectrum changes by a few per cent across a band.
LINE_BAND_SHARE = 1.0 / 16.0


def pooled(tp: TaperedPeriodogram, n_single: int = 256, ratio: float = 1.02,
           fine: list[LineWindow] | tuple = ()) -> BandedPeriodogram:
    """``tp`` with its lowest ``n_single`` frequencies single and the rest in bands of width ratio·ω; inside ``fine``
    windows a band spans at most :data:`LINE_BAND_SHARE` of max(bandwidth, distance from the centre), ≥ 1 frequency."""
    m, jmax = tp.m, tp.omega.size
    step = 2.0 * math.pi / m
    cap = np.full(jmax + 2, jmax + 2, dtype=np.int64)
    cap[: n_single + 1] = 1
    for w in fine:
        j0, j1 = max(int(w.lo / step) - 1, 0), min(int(w.hi / step) + 2, jmax + 2)
        omega = np.arange(j0, j1) * step
        width = LINE_BAND_SHARE * np.maximum(w.bandwidth, np.abs(omega - w.centre)) / step
        cap[j0:j1] = np.minimum(cap[j0:j1], np.maximum(width.astype(np.int64), 1))
    edges = [0]
    while edges[-1] < jmax:
        e = edges[-1]
        edges.append(min(e + 1 + min(max(0, int(e * ratio) - e - 1), int(cap[e + 1]) - 1), jmax))
    edges = np.array(edges)
    counts = np.diff(edges)
    csum, wsum = tp.cumulative
    power = csum[edges[1:]] - csum[edges[:-1]]
    centre = (wsum[edges[1:]] - wsum[edges[:-1]]) / counts
    return BandedPeriodogram(centre, counts.astype(float), power)


def banded_periodogram(y: np.ndarray, n_single: int = 256, ratio: float = 1.02,
                       fine: list[LineWindow] | tuple = ()) -> BandedPeriodogram:
    """:func:`pooled` of the :func:`tapered_periodogram` of ``y``."""
    return pooled(tapered_periodogram(y), n_single, ratio, fine)


def line_windows(starts: list[list[Component]], dt: float) -> list[LineWindow]:
    """Windows ±max(20 bandwidths, 2 % of the frequency) around every OSC line of ``starts``."""
    out = []
    for start in starts:
        for c in start:
            if c.name == "OSC":
                f0, b = c.params()["frequency"], c.params()["bandwidth"]
                half = max(20.0 * b, 0.02 * f0)
                f_lo, f_hi = max(f0 - half, 0.0), f0 + half
                to_omega = 2.0 * math.pi * dt
                out.append(LineWindow(f_lo * to_omega, f_hi * to_omega, f0 * to_omega, b * to_omega))
    return out


def osc_start_frequencies(bp: BandedPeriodogram, dt: float, count: int, half_window: int = 12) -> list[float]:
    """Frequencies [Hz] of the ``count`` strongest peaks of band power over its running median, strongest first."""
    mean = bp.power / bp.count
    k = np.arange(mean.size)
    floor = np.array([np.median(mean[max(0, i - half_window): i + half_window + 1]) for i in k])
    ratio = mean / np.maximum(floor, np.finfo(float).tiny)
    peaks = [i for i in k[1:-1] if ratio[i] >= ratio[i - 1] and ratio[i] >= ratio[i + 1]]
    peaks.sort(key=lambda i: -ratio[i])
    return [float(bp.omega[i] / (2.0 * math.pi * dt)) for i in peaks[:count]]


def difference_spectrum(components: list[Component], omega: np.ndarray, dt: float) -> np.ndarray:
    """Spectral density per sample of Δy for ``components`` at ω [rad/sample] (RR contributes nothing)."""
    c = 2.0 - 2.0 * np.cos(omega)
    s = np.zeros_like(omega)
    for comp in components:
        if isinstance(comp, WN):
            s += comp.per_sample(dt)["sigma2_wn"] * c
        elif isinstance(comp, RW):
            s += comp.per_sample(dt)["sigma2_rw"]
        elif isinstance(comp, QN):
            s += comp.per_sample(dt)["sigma2_qn"] * c * c
        elif isinstance(comp, GM):
            ps = comp.per_sample(dt)
            phi = ps["phi"]
            s += ps["sigma2_drive"] * c / (1.0 - 2.0 * phi * np.cos(omega) + phi * phi)
        elif isinstance(comp, DLPF):  # its block is 5 × 5 at order 4: a solve per frequency
            s += comp.sample_spectrum(omega, dt) * c
        elif not isinstance(comp, RR):
            blk = comp.block(dt)
            s += block_spectrum(blk.phi, blk.q, blk.h, omega) * c
    return s


def whittle_loglik(s: np.ndarray, bp: BandedPeriodogram) -> float:
    """Banded Whittle log-likelihood −Σ_b [n_b ln S_b + P_b/S_b] (up to a constant), P_b a band's summed periodogram."""
    return -float(np.sum(bp.count * np.log(s) + bp.power / s))


def components_loglik(components: list[Component], bp: BandedPeriodogram, dt: float) -> float:
    """:func:`whittle_loglik` of ``components``' :func:`difference_spectrum` on ``bp``; −inf where S_Δ ≤ 0."""
    s = difference_spectrum(components, bp.omega, dt)
    return whittle_loglik(s, bp) if np.all(s > 0) else -math.inf


def block_spectrum(phi: np.ndarray, q: np.ndarray, h: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Spectral density per sample of y_k = h x_k, x_{k+1} = Φ x_k + w_k, var w = Q: S(ω) = h G Q Gᴴ hᵀ, G = (e^{iω}
    I − Φ)⁻¹ (closed form for diagonal and 2 × 2 Φ)."""
    z = np.exp(1j * np.asarray(omega))
    n = phi.shape[0]
    if np.count_nonzero(phi - np.diag(np.diag(phi))) == 0:  # (zI − Φ)⁻¹ is diagonal
        hg = h[None, :] / (z[:, None] - np.diag(phi)[None, :])
    elif n == 2:
        m00, m11 = z - phi[0, 0], z - phi[1, 1]
        m01, m10 = -phi[0, 1], -phi[1, 0]
        det = m00 * m11 - m01 * m10
        hg = np.stack([h[0] * m11 - h[1] * m10, h[1] * m00 - h[0] * m01], axis=1) / det[:, None]
    else:  # h G = solve((zI − Φ)ᵀ, hᵀ) per frequency (cheaper than forming the inverse)
        a = np.swapaxes(z[:, None, None] * np.eye(n) - phi[None, :, :], 1, 2)
        hg = np.linalg.solve(a, np.broadcast_to(h.astype(complex), (z.size, n))[:, :, None])[:, :, 0]
    return np.real(np.sum((hg @ q) * hg.conj(), axis=1))


def with_log_parameters(components: list[Component], keys: list[tuple[int, str]],
                        x: np.ndarray) -> list[Component]:
    """``components`` with parameter ``keys[j]`` = (index, name) set to exp(x[j]); ValueError outside its range."""
    params = [dict(c.params()) for c in components]
    for (i, name), v in zip(keys, x, strict=True):
        params[i][name] = math.exp(v) if v < 700.0 else math.inf  # beyond exp's range: the component refuses it
    return [type(c)(**p) for c, p in zip(components, params, strict=True)]


#: Step [log-parameter] of the central differences of one component's share of a likelihood's statistics.
DIFFERENCE_STEP = 1e-4


@dataclass(frozen=True)
class Shares:
    """Each component's share of a likelihood's statistics (``each``, in the components' order) and the closed-form
    ∂share/∂ln ϑ of those that have them (``shapes``: component index → shape parameter name → array)."""

    each: list[np.ndarray]
    shapes: dict[int, dict[str, np.ndarray]]

    @property
    def total(self) -> np.ndarray:
        """The statistics of the sum of the components: Σ of the shares."""
        return np.sum(self.each, axis=0)


@dataclass
class ComponentParts:
    """One component's share of a likelihood's statistics (``computed(c)``, an array additive over components), a
    scale-only component's computed once per shape at one scale and rescaled by scale² (kept per instance: one per set
    of frequencies or lags); ``closed(components)``, where given, the shares and shape derivatives in closed form of
    those components that have them (:func:`.exponential_parts.closed_parts`), all at once."""

    computed: Callable[[Component], np.ndarray]
    closed: Callable[[list[Component]], exponential_parts.ClosedParts] | None = None
    memo: dict = field(default_factory=dict)

    def __call__(self, c: Component) -> np.ndarray:
        split = c.scale_only()
        if split is None:  # its shape moves: entries would pile up
            return self.computed(c)
        scale, fixed = split
        key = (type(c), fixed)
        if key not in self.memo:
            self.memo[key] = scale, self.computed(c)
        at, part = self.memo[key]
        return part * (scale / at) ** 2

    def evaluate(self, current: list[Component]) -> Shares:
        """The :class:`Shares` of ``current``: closed-form where :attr:`closed` gives them, else by ``self(c)``."""
        found, shapes = self.closed(current) if self.closed is not None else ({}, {})
        return Shares([found[i] if i in found else self(c) for i, c in enumerate(current)], shapes)

    def columns(self, current: list[Component], keys: list[tuple[int, str]], x: np.ndarray,
                shares: Shares) -> list[np.ndarray | None]:
        """∂(Σ_c part(c))/∂x_j for the log-parameters ``keys`` at ``x`` (``current`` the components there, ``shares``
        their :meth:`evaluate`): through the one component c of x_j, exact (2·part(c)) for a component's scale, the
        closed form where ``shares`` holds one, by central differences of :data:`DIFFERENCE_STEP` otherwise (None
        where no step stays inside the component's domain)."""
        out: list[np.ndarray | None] = []
        for j, (i, name) in enumerate(keys):
            if name == current[i].scale_name:
                out.append(2.0 * shares.each[i])
                continue
            if name in shares.shapes.get(i, {}):
                out.append(shares.shapes[i][name])
                continue

            def moved(h: float, i: int = i, name: str = name, at: float = float(x[j])) -> np.ndarray:
                return self(with_log_parameters([current[i]], [(0, name)], np.array([at + h]))[0])

            out.append(derivative_in_domain(moved, DIFFERENCE_STEP, lambda i=i: shares.each[i]))
        return out

    def gradient(self, current: list[Component], keys: list[tuple[int, str]], x: np.ndarray, shares: Shares,
                 weights: np.ndarray) -> np.ndarray:
        """∂/∂x_j of a likelihood whose derivative in the summed parts Σ_c part(c) is ``weights``, by the chain rule
        through :meth:`columns` (zero where a column is None)."""
        return np.array([0.0 if d is None else float(weights @ d) for d in self.columns(current, keys, x, shares)])


def spectrum_parts(omega: np.ndarray, dt: float) -> ComponentParts:
    """Each component's :func:`difference_spectrum` at ``omega`` [rad/sample], those with exponential terms with their
    closed-form shape derivatives there (:func:`.exponential_parts.closed_parts`): the parts of the banded Whittle
    likelihood."""
    factors = [lambda w: exponential_parts.difference_spectrum_factor(w, omega)]

    def closed(components: list[Component]) -> exponential_parts.ClosedParts:
        return exponential_parts.closed_parts(components, dt, factors, lambda shares: shares[0])

    return ComponentParts(lambda c: difference_spectrum([c], omega, dt), closed)


def loglik_and_gradient(components: list[Component], keys: list[tuple[int, str]], x: np.ndarray,
                        bp: BandedPeriodogram, parts: ComponentParts) -> tuple[float, np.ndarray]:
    """:func:`components_loglik` with the log-parameters ``keys`` set to ``x``, and its gradient in ``x``:
    ∂ℓ/∂ϑ_j = Σ_b (P_b/S_b − n_b)/S_b · ∂S_c/∂ϑ_j (:meth:`ComponentParts.gradient`, ``parts`` the components'
    :func:`difference_spectrum` on ``bp``). ValueError outside a domain; (−inf, zeros) where S_Δ ≤ 0."""
    current = with_log_parameters(components, keys, x)
    shares = parts.evaluate(current)
    s = shares.total
    if not np.all(s > 0):
        return -math.inf, np.zeros(x.size)
    return whittle_loglik(s, bp), parts.gradient(current, keys, x, shares, (bp.power / s - bp.count) / s)


#: Largest |∂ℓ/∂ln ϑ| at which :func:`whittle_fit`'s climb ``to_maximum`` stops.
MAXIMUM_GRADIENT_TOLERANCE = 0.05


def whittle_fit(start: list[Component], y: np.ndarray, dt: float, periodogram: BandedPeriodogram | None = None,
                bounds: dict[str, tuple[float, float]] | None = None, *,
                to_maximum: bool = False) -> tuple[float, list[Component]]:
    """(Whittle log-likelihood up to a constant, fitted components) maximised over the log-parameters from ``start``
    (RR held) by L-BFGS-B with :func:`loglik_and_gradient`; ``bounds``: physical range per parameter name (default
    GM τ from dt/2 to 100 records). L-BFGS-B's own stopping rule is relative to |ℓ| (~N), which leaves a likelihood
    whose parameters show in few frequencies short of its maximum (on a measured axis a tenth of the climbs by more
    than one unit, some by hundreds); ``to_maximum`` climbs on from there relative to the value reached, until
    |∂ℓ/∂ln ϑ| < :data:`MAXIMUM_GRADIENT_TOLERANCE`: for values compared across structures, where a start's
    good-enough is not. A climb that stays at its start is redone in units of the start's information
    (:func:`_scaled_climb`)."""
    bp = periodogram or banded_periodogram(y)
    keys = [(i, k) for i, c in enumerate(start) if not isinstance(c, RR) for k in c.parameter_names]
    x0 = np.log([start[i].params()[k] for i, k in keys])
    t_total = y.size * dt
    parts = spectrum_parts(bp.omega, dt)

    def negll(x: np.ndarray) -> tuple[float, np.ndarray]:
        try:
            ll, grad = loglik_and_gradient(start, keys, x, bp, parts)
        except ValueError:
            return 1e300, np.zeros(x.size)
        return (1e300, np.zeros(x.size)) if ll == -math.inf else (-ll, -grad)

    ranges = bounds or {"tau": (dt / 2.0, 100.0 * t_total)}
    box = []
    for (_, k), v in zip(keys, x0, strict=True):
        if k in ranges:
            box.append((math.log(ranges[k][0]), math.log(ranges[k][1])))
        else:
            box.append((v - 30.0, v + 30.0))
    x0 = np.clip(x0, [b[0] for b in box], [b[1] for b in box])
    res = minimize(negll, x0, jac=True, method="L-BFGS-B", bounds=box, options={"maxiter": 500})
    x_reached, reached = res.x, float(res.fun)
    if np.array_equal(res.x, x0) and reached < 1e300:  # stalled at its start: redone in units of its information
        x_reached, reached = _scaled_climb(negll, x0, box, whittle_information(
            with_log_parameters(start, keys, x0), np.empty(0), dt, periodogram=bp), (x_reached, reached))
    if not to_maximum or reached >= 1e300:
        return -reached, with_log_parameters(start, keys, x_reached)

    def from_reached(x: np.ndarray) -> tuple[float, np.ndarray]:
        value, gradient = negll(x)
        return value - reached, gradient

    on = minimize(from_reached, x_reached, jac=True, method="L-BFGS-B", bounds=box,
                  options={"maxiter": 500, "ftol": 1e-15, "gtol": MAXIMUM_GRADIENT_TOLERANCE})
    x = on.x if on.fun < 0.0 else x_reached
    return -(reached + min(float(on.fun), 0.0)), with_log_parameters(start, keys, x)


def _scaled_climb(negll: Callable[[np.ndarray], tuple[float, np.ndarray]], x0: np.ndarray,
                  box: list[tuple[float, float]], information: np.ndarray,
                  unscaled: tuple[np.ndarray, float]) -> tuple[np.ndarray, float]:
    """(x, −ℓ) of L-BFGS-B on ``negll`` from ``x0`` in units of the start's Fisher information per log-parameter
    (x = x0 + η/√I_jj, within ``box``), or ``unscaled`` (x, −ℓ) where that is no better. Unscaled, the first step is
    the whole gradient (~N in the white noise's log-density) and may reach the box's corners, where a resonance is not
    defined (bandwidth above its frequency), and L-BFGS-B stops at the start."""
    diagonal = np.diag(information)
    scale = np.sqrt(np.where(diagonal > 0.0, diagonal, 1.0))

    def in_units(eta: np.ndarray) -> tuple[float, np.ndarray]:
        value, gradient = negll(x0 + eta / scale)
        return value, gradient / scale

    eta_box = [((lo - x) * k, (hi - x) * k) for (lo, hi), x, k in zip(box, x0, scale, strict=True)]
    res = minimize(in_units, np.zeros(x0.size), jac=True, method="L-BFGS-B", bounds=eta_box,
                   options={"maxiter": 500})
    return (x0 + res.x / scale, float(res.fun)) if res.fun < unscaled[1] else unscaled


def whittle_information(components: list[Component], y: np.ndarray, dt: float,
                        periodogram: BandedPeriodogram | None = None) -> np.ndarray:
    """Expected (Fisher) information of the banded Whittle likelihood in the log-parameters (as
    :class:`~.mle.Parameterisation`): Σ_b n_b ∂ln S_b/∂ϑ ∂ln S_b/∂ϑᵀ, ∂S/∂ϑ through the one component of ϑ
    (:meth:`ComponentParts.columns`: exact in a scale, closed form for exponential terms, central differences
    otherwise; zero where no step is inside a domain). Positive semi-definite; the finish's metric
    (:func:`.mle.maximise`)."""
    bp = periodogram or banded_periodogram(y)
    keys = [(i, k) for i, c in enumerate(components) if not isinstance(c, RR) for k in c.parameter_names]
    x0 = np.log([components[i].params()[k] for i, k in keys])
    parts = spectrum_parts(bp.omega, dt)
    shares = parts.evaluate(components)
    s = shares.total
    jac = np.column_stack([np.zeros(bp.omega.size) if d is None else d / s
                           for d in parts.columns(components, keys, x0, shares)])
    return (jac * bp.count[:, None]).T @ jac


def fisher_information(components: list[Component], n: int, dt: float) -> np.ndarray:
    """Whittle's asymptotic Fisher information of ``n`` samples in the log-parameters, from the model alone
    (P. Whittle, Ark. Mat. 2, 1953: Σ_j ∇ln S(ω_j) ∇ln S(ω_j)ᵀ over the positive Fourier frequencies of the n − 1
    differences, pooled as :func:`pooled`, finely around OSC lines)."""
    m = int(n) - 1
    jmax = (m - 1) // 2
    if jmax < 8:
        raise InputError("too few samples for a spectral information")
    omega = 2.0 * math.pi * np.arange(1, jmax + 1) / m
    grid = pooled(TaperedPeriodogram(omega, np.zeros(jmax), m), fine=line_windows([components], dt))
    return whittle_information(components, np.empty(0), dt, periodogram=grid)
