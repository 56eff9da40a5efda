"""Hypotheses about a sensor's error model and their point-mass grids (paper 002 eqs. 3, 21–23): a constant bias,
dynamic RW/GM components and optional WN, a uniform prior range per unknown parameter. Continuous-time parameters
(``RW.random_walk`` [u/s/√Hz], ``GM.tau`` [s], ``GM.sigma`` [u], ``WN.noise_density`` [u/√Hz]; paper 002's σ_w, σ_m,
σ_v per sample are ``random_walk·√Δt``, ``sigma``, ``noise_density/√Δt``). Beyond the paper: cells weighted by width,
block averaging (:func:`averaged_dynamic_block`); why: docs/hypotheses.md, "How it works"."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..noise.components import GM, RW, WN
from ..noise.modelspec import structure_name

#: Unknown parameters of each supported component, in grid order.
COMPONENT_PARAMETERS: dict[str, tuple[str, ...]] = {
    "RW": ("random_walk",),
    "GM": ("tau", "sigma"),
    "WN": ("noise_density",),
}
#: Components whose state enters the bank (WN is measurement noise).
DYNAMIC_COMPONENTS: tuple[str, ...] = ("RW", "GM")


@dataclass(frozen=True)
class ParameterPrior:
    """Uniform prior range of one parameter and its grid (paper 002 eq. 3); InputError when invalid. ``name``
    ``"<COMPONENT>.<parameter>"``; ``low``, ``high`` the range, continuous-time units (equal: known); ``n`` grid cells
    (1 when known); ``spacing`` ``"linear"`` or ``"log"``; ``grid_low``, ``grid_high`` an optional sub-range of the grid
    (:func:`refine_hypothesis_set`), its weights still fractions of the whole range."""

    name: str
    low: float
    high: float
    n: int = 16
    spacing: str = "linear"
    grid_low: float | None = None
    grid_high: float | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.low) and math.isfinite(self.high)) or self.low < 0 or self.high < self.low:
            raise InputError(f"prior range of {self.name} must be finite with 0 <= low <= high, got "
                             f"[{self.low}, {self.high}]")
        if self.spacing not in ("linear", "log"):
            raise InputError(f"spacing of {self.name} must be 'linear' or 'log', got {self.spacing!r}")
        if int(self.n) != self.n or self.n < 1:
            raise InputError(f"grid size of {self.name} must be an integer >= 1, got {self.n!r}")
        if self.high > self.low and self.n < 2:
            raise InputError(f"{self.name} has a range [{self.low}, {self.high}] but a grid of {self.n} "
                             "point(s): use n >= 2, or low == high for a known value")
        if self.spacing == "log" and self.low <= 0:
            raise InputError(f"log spacing of {self.name} needs low > 0, got {self.low}")
        if self.name.split(".")[-1] in ("tau", "sigma", "random_walk") and self.low <= 0:
            raise InputError(f"{self.name} must be > 0 over its prior range, got low = {self.low}")
        g_lo = self.low if self.grid_low is None else self.grid_low
        g_hi = self.high if self.grid_high is None else self.grid_high
        if not (self.low <= g_lo <= g_hi <= self.high) or (self.high > self.low and not g_hi > g_lo):
            raise InputError(f"grid range [{g_lo}, {g_hi}] of {self.name} must lie inside its prior range "
                             f"[{self.low}, {self.high}] and be non-empty")

    @property
    def known(self) -> bool:
        return self.high == self.low

    @property
    def mean(self) -> float:
        """Prior mean (the denominator of the RSD, paper 002 eq. 20)."""
        return 0.5 * (self.low + self.high)

    def edges(self) -> np.ndarray:
        """Cell edges of the grid (n + 1 values from grid_low to grid_high)."""
        lo = self.low if self.grid_low is None else self.grid_low
        hi = self.high if self.grid_high is None else self.grid_high
        return np.geomspace(lo, hi, self.n + 1) if self.spacing == "log" else np.linspace(lo, hi, self.n + 1)

    def cells(self) -> tuple[np.ndarray, np.ndarray]:
        """Grid points (cell centres) and prior weights (cell widths over the range's width)."""
        if self.known:
            return np.array([self.low]), np.ones(1)
        edges = self.edges()
        centres = np.sqrt(edges[:-1] * edges[1:]) if self.spacing == "log" else 0.5 * (edges[:-1] + edges[1:])
        return centres, np.diff(edges) / (self.high - self.low)


@dataclass(frozen=True)
class Hypothesis:
    """One error-model structure h_k with the priors of its parameters θ^k; InputError when invalid. ``components``
    from ``RW``, ``GM``, ``WN``, each at most once, plus a bias state (eqs. 21–22; no ``WN``: R = 0); ``priors`` one
    :class:`ParameterPrior` per parameter; ``probability`` prior Pr(H = h_k) (normalised over the set); ``name`` its
    label (default the canonical structure name, e.g. ``"WN+RW"``)."""

    components: tuple[str, ...]
    priors: tuple[ParameterPrior, ...]
    probability: float = 1.0
    name: str = ""

    def __post_init__(self) -> None:
        comps = tuple(c.upper() for c in self.components)
        object.__setattr__(self, "components", comps)
        label = self.name or structure_name(list(comps))  # canonical: WN+RW whatever the components' order
        object.__setattr__(self, "name", label)
        if not comps:
            raise InputError(f"hypothesis {label!r} has no components")
        for c in comps:
            if c not in COMPONENT_PARAMETERS:
                raise InputError(f"hypothesis {label!r}: component {c!r} is not supported by the bank "
                                 f"(use {', '.join(COMPONENT_PARAMETERS)})")
        if len(set(comps)) != len(comps):
            raise InputError(f"hypothesis {label!r}: each component may appear once")
        if not any(c in DYNAMIC_COMPONENTS for c in comps):
            raise InputError(f"hypothesis {label!r} needs a dynamic component (RW or GM)")
        expected = [f"{c}.{p}" for c in comps for p in COMPONENT_PARAMETERS[c]]
        given = [p.name for p in self.priors]
        if sorted(given) != sorted(expected):
            raise InputError(f"hypothesis {label!r}: priors {given} do not match its parameters {expected}")
        order = {name: i for i, name in enumerate(expected)}
        object.__setattr__(self, "priors", tuple(sorted(self.priors, key=lambda p: order[p.name])))
        if not (math.isfinite(self.probability) and self.probability > 0):
            raise InputError(f"hypothesis {label!r}: prior probability must be > 0, got {self.probability}")

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.priors)

    @property
    def n_states(self) -> int:
        return sum(c in DYNAMIC_COMPONENTS for c in self.components) + 1

    def grid(self) -> tuple[np.ndarray, np.ndarray]:
        """Grid θ^{kj} (M_k, p) and prior weights μ_0^{kj} (M_k,) (eq. 3), summing to 1 or to a refined box's mass."""
        cells = [p.cells() for p in self.priors]
        points = np.array(list(itertools.product(*[c[0] for c in cells])), dtype=float)
        weights = np.array([math.prod(w) for w in itertools.product(*[c[1] for c in cells])], dtype=float)
        return points.reshape(len(weights), len(cells)), weights


@dataclass(frozen=True)
class HypothesisSet:
    """The competing hypotheses and the bank's settings; InputError when invalid. ``hypotheses`` the
    :class:`Hypothesis` tuple; ``dt`` input sampling period [s]; ``block`` input samples per bank sample; ``gamma``
    decision threshold γ on the largest posterior probability (paper 002 section 2); ``bias_sigma`` prior std of the
    constant bias [u]; ``gain_tolerance`` the Riccati iteration stops once no gain or relative innovation variance
    changes by more than this in a step (0 = never)."""

    hypotheses: tuple[Hypothesis, ...]
    dt: float
    gamma: float = 0.8
    block: int = 1
    bias_sigma: float = 1.0
    gain_tolerance: float = 1e-10
    extra: dict = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        if len(self.hypotheses) < 1:
            raise InputError("a hypothesis set needs at least one hypothesis")
        names = [h.name for h in self.hypotheses]
        if len(set(names)) != len(names):
            raise InputError(f"hypothesis names must be unique, got {names}")
        if not (math.isfinite(self.dt) and self.dt > 0):
            raise InputError(f"sampling period dt must be > 0 s, got {self.dt}")
        if not (0.5 <= self.gamma <= 1.0):
            raise InputError(f"decision threshold gamma must be in [0.5, 1], got {self.gamma}")
        if int(self.block) != self.block or self.block < 1:
            raise InputError(f"block (samples averaged per bank step) must be an integer >= 1, got {self.block}")
        if not (math.isfinite(self.bias_sigma) and self.bias_sigma >= 0):
            raise InputError(f"bias_sigma must be >= 0, got {self.bias_sigma}")
        if not (self.gain_tolerance >= 0):
            raise InputError(f"gain_tolerance must be >= 0, got {self.gain_tolerance}")

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(h.name for h in self.hypotheses)

    @property
    def bank_dt(self) -> float:
        """Sampling period of the bank's samples [s] (``dt·block``)."""
        return self.dt * self.block


def averaged_dynamic_block(phi: float, q: float, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Exact (Φ, Q) of x_k = φ x_{k−1} + w_k (var w = q) through m-sample averages, states (e_j, a_j); φ = 1: RW::

        e_j = φ^m e_{j−1} + d_j,  a_j = c e_{j−1} + u_j,  c = (1/m) Σ_{i=1..m} φ^i,  g_l = (1/m) Σ_{i=l..m} φ^{i−l},
        Q = q·[[Σα², Σαg], [Σαg, Σg²]],  α_l = φ^{m−l},  H = [0, 1];  white noise averages to σ²_v/m.
    """
    lags = np.arange(m)  # l' = m − l = 0..m−1
    alpha = phi ** lags[::-1]  # α_l = φ^{m−l}, l = 1..m
    powers = phi ** np.arange(m)  # φ^0..φ^{m−1}
    tail = np.cumsum(powers)  # Σ_{r=0}^{s} φ^r
    g = tail[::-1] / m  # g_l = (1/m) Σ_{r=0}^{m−l} φ^r
    c = float(np.sum(phi ** np.arange(1, m + 1))) / m
    Phi = np.array([[phi**m, 0.0], [c, 0.0]])
    Q = q * np.array([[alpha @ alpha, alpha @ g], [alpha @ g, g @ g]])
    return Phi, Q


@dataclass(frozen=True)
class BankModel:
    """Every filter's matrices stacked, filter index last (padded states zero): ``phi_kron`` (n², n², F) = Φ ⊗ Φ, ``q``
    (n², F), ``h`` (n, F), ``hh`` (n², F), ``phi`` (n, n, F), ``r``, ``p0``; ``slices[k]``, ``theta[k]`` (M_k, p_k),
    ``log_mu0`` (F,), ``log_prior`` (K,)."""

    n: int
    phi: np.ndarray
    phi_kron: np.ndarray
    q: np.ndarray
    h: np.ndarray
    hh: np.ndarray
    r: np.ndarray
    p0: np.ndarray
    slices: tuple[slice, ...]
    theta: tuple[np.ndarray, ...]
    log_mu0: np.ndarray
    log_prior: np.ndarray
    state_names: tuple[tuple[str, ...], ...]

    @property
    def n_filters(self) -> int:
        return int(self.r.shape[0])


def _filter_matrices(hyp: Hypothesis, theta: np.ndarray, dt: float, m: int, bias_sigma: float):
    """Φ, Q, h, R, P₀ of one grid point of ``hyp`` (unpadded) and the state names."""
    values = dict(zip(hyp.parameter_names, theta, strict=True))
    blocks, names = [], []
    r = 0.0
    for comp in hyp.components:
        if comp == "WN":
            r = WN(values["WN.noise_density"]).block(dt).r / m if values["WN.noise_density"] > 0 else 0.0
            continue
        if comp == "RW":
            blk, var0 = RW(values["RW.random_walk"]).block(dt), 0.0
        else:
            gm = GM(values["GM.tau"], values["GM.sigma"])
            blk, var0 = gm.block(dt), gm.sigma**2
        phi, q = float(blk.phi[0, 0]), float(blk.q[0, 0])
        if m == 1:
            blocks.append((np.array([[phi]]), np.array([[q]]), np.ones(1), np.array([var0])))
            names.append(comp)
        else:
            Phi, Q = averaged_dynamic_block(phi, q, m)
            blocks.append((Phi, Q, np.array([0.0, 1.0]), np.array([var0, 0.0])))
            names += [f"{comp}_end", comp]
    blocks.append((np.ones((1, 1)), np.zeros((1, 1)), np.ones(1), np.array([bias_sigma**2])))
    names.append("bias")
    n = sum(b[2].size for b in blocks)
    Phi, Q, h, p0 = np.zeros((n, n)), np.zeros((n, n)), np.zeros(n), np.zeros(n)
    i = 0
    for bphi, bq, bh, bp0 in blocks:
        s = slice(i, i + bh.size)
        Phi[s, s], Q[s, s], h[s], p0[s] = bphi, bq, bh, bp0
        i += bh.size
    return Phi, Q, h, r, np.diag(p0), tuple(names)


def build_bank_model(hset: HypothesisSet) -> BankModel:
    """Stack the Kalman-filter matrices of every grid point of every hypothesis (paper 002 step 1)."""
    m = int(hset.block)
    per_filter, slices, thetas, log_mu0, state_names = [], [], [], [], []
    for hyp in hset.hypotheses:
        theta, mu0 = hyp.grid()
        start = len(per_filter)
        for th in theta:
            per_filter.append(_filter_matrices(hyp, th, hset.dt, m, hset.bias_sigma))
        slices.append(slice(start, len(per_filter)))
        thetas.append(theta)
        log_mu0.append(np.log(mu0))
        state_names.append(per_filter[-1][5])
    n = max(f[0].shape[0] for f in per_filter)
    F = len(per_filter)
    phi, q, h, p0 = np.zeros((n, n, F)), np.zeros((n, n, F)), np.zeros((n, F)), np.zeros((n, n, F))
    r = np.zeros(F)
    for j, (Phi, Q, hv, rv, P0, _) in enumerate(per_filter):
        d = hv.size
        phi[:d, :d, j], q[:d, :d, j], h[:d, j], p0[:d, :d, j], r[j] = Phi, Q, hv, P0, rv
    phi_kron = np.einsum("ikf,jlf->ijklf", phi, phi).reshape(n * n, n * n, F)
    hh = np.einsum("if,jf->ijf", h, h).reshape(n * n, F)
    prior = np.array([hyp.probability for hyp in hset.hypotheses], dtype=float)
    return BankModel(
        n=n, phi=phi, phi_kron=np.ascontiguousarray(phi_kron), q=q.reshape(n * n, F), h=h, hh=hh, r=r,
        p0=p0.reshape(n * n, F), slices=tuple(slices), theta=tuple(thetas),
        log_mu0=np.concatenate(log_mu0), log_prior=np.log(prior / prior.sum()), state_names=tuple(state_names),
    )


def refine_hypothesis_set(hset: HypothesisSet, theta: dict[str, dict[str, float]],
                          theta_std: dict[str, dict[str, float]], n_sigma: float = 6.0) -> HypothesisSet:
    """Grid refinement (beyond paper 002): each unknown parameter's grid re-centred on θ̂ ± max(n_sigma·std, 1 cell)
    (log grids: ·/÷ exp(max(n_sigma·std/θ̂, 1 log cell))), clipped to the prior range, same cells, weights as before."""
    new_h = []
    for hyp in hset.hypotheses:
        priors = []
        for p in hyp.priors:
            if p.known:
                priors.append(p)
                continue
            mean = theta[hyp.name][p.name]
            std = theta_std[hyp.name][p.name]
            e = p.edges()
            if p.spacing == "log":
                cell = float(np.max(np.log(e[1:] / e[:-1])))
                half = max(n_sigma * std / mean, cell)
                lo, hi = mean * math.exp(-half), mean * math.exp(half)
            else:
                cell = float(np.max(np.diff(e)))
                half = max(n_sigma * std, cell)
                lo, hi = mean - half, mean + half
            lo, hi = max(lo, p.low), min(hi, p.high)
            priors.append(ParameterPrior(p.name, p.low, p.high, p.n, p.spacing, grid_low=lo, grid_high=hi))
        new_h.append(Hypothesis(hyp.components, tuple(priors), hyp.probability, hyp.name))
    return HypothesisSet(tuple(new_h), dt=hset.dt, gamma=hset.gamma, block=hset.block, bias_sigma=hset.bias_sigma,
                         gain_tolerance=hset.gain_tolerance)
