"""Linear-Gaussian state-space model of one sensor axis from error components, paper 000 (Stebler et al. 2011) eqs.
(4)–(5)::

    x_{t+1} = Φ x_t + w_t + u,          w_t ~ N(0, Q)
    y_t     = H x_t + bᵀ z_t + v_t,     v_t ~ N(0, R),      x_1 ~ N(μ, Σ)

θ-matrices ``vec(M) = f + D·m`` (eqs. 7–9); beyond the paper, regressors z_t (b by GLS) and Σ = P̄ (:mod:`.steady`)."""

from __future__ import annotations

import functools
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import InputError
from ..noise.components import COMPONENT_TYPES, GM, RR, RW, WN, Component, StateBlock
from .riccati import steady_prediction_covariance

#: Matrix names of θ in the order the EM updates them (paper 000 §3.3).
MATRIX_NAMES: tuple[str, ...] = ("u", "mu", "phi", "h", "q", "r", "b")


@dataclass(frozen=True)
class BlockInfo:
    """Where a component lives: ``name``, ``states``, ``regressor`` (index in b) or ``input_state`` (RR's u)."""

    name: str
    states: tuple[int, ...] = ()
    regressor: int | None = None
    input_state: int | None = None


@dataclass
class StateSpace:
    """A univariate-measurement linear-Gaussian state-space model with fixed/free masks.

    Attributes
    ----------
    phi, q, sigma : (p, p) Φ, Q, Σ (used when ``sigma_mode='fixed'``); h, u, mu : (p,) H, u, μ; r : R per sample
    b : (k,) coefficients of the regressors z_t (``regressors``); *_free : bool masks (True: estimated); dt : period [s]
    blocks : :class:`BlockInfo`; sigma_mode : ``'steady'`` (Σ = P̄) or ``'fixed'``; sinusoid_omega : ω [rad/sample] per
        regressor (NaN: not a sinusoid; 0: a line c₀ + c₁t, :func:`.harmonic.sinusoid_omega`), or empty
    """

    phi: np.ndarray
    q: np.ndarray
    h: np.ndarray
    r: float
    u: np.ndarray
    mu: np.ndarray
    sigma: np.ndarray
    b: np.ndarray
    phi_free: np.ndarray
    q_free: np.ndarray
    h_free: np.ndarray
    r_free: bool
    u_free: np.ndarray
    mu_free: np.ndarray
    b_free: np.ndarray
    dt: float
    blocks: tuple[BlockInfo, ...] = ()
    regressors: tuple[str, ...] = ()
    sigma_mode: str = "steady"
    sinusoid_omega: tuple[float, ...] = ()
    _steady_cache: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def n_states(self) -> int:
        return int(self.phi.shape[0])

    @property
    def n_regressors(self) -> int:
        return int(self.b.shape[0])

    def copy(self, **changes) -> StateSpace:
        """A deep copy with some attributes replaced; P̄ kept with the Φ, Q, H, R it solves (reused while the copy's
        are the same, e.g. where only the means changed; else the start of its Riccati solve)."""
        fields = {
            k: (np.array(v, copy=True) if isinstance(v, np.ndarray) else v)
            for k, v in self.__dict__.items() if k != "_steady_cache"
        }
        fields.update(changes)
        cached = self._steady_cache.get("value")
        if cached is not None:
            fields["_steady_cache"] = {"value": (cached[0], cached[1].copy())}
        else:
            guess = self._steady_cache.get("guess")
            fields["_steady_cache"] = {"guess": guess} if guess is not None else {}
        return replace(self, **fields)

    # -- vec(M) = f + D·m (paper 000 eqs. 7–9) -------------------------------------------------------------
    def matrix(self, name: str) -> np.ndarray:
        """θ-matrix ``name`` (one of :data:`MATRIX_NAMES`) as a 2-D array (vectors as columns)."""
        value = np.atleast_1d(np.asarray(getattr(self, name), dtype=float))
        return value.reshape(-1, 1) if value.ndim == 1 else value

    def free_mask(self, name: str) -> np.ndarray:
        mask = np.atleast_1d(np.asarray(getattr(self, f"{name}_free"), dtype=bool))
        return mask.reshape(-1, 1) if mask.ndim == 1 else mask

    def design(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """``(f, D)`` with ``vec(M) = f + D·m``: f = vec(M_fixed), D maps the free values m into vec(M_free)."""
        value, mask = self.matrix(name), self.free_mask(name)
        vec_mask = mask.flatten(order="F")
        f = np.where(vec_mask, 0.0, value.flatten(order="F"))
        D = np.eye(vec_mask.size)[:, vec_mask]
        return f, D

    def free_values(self, name: str) -> np.ndarray:
        """The free values m of matrix ``name`` (column-major order)."""
        return self.matrix(name).flatten(order="F")[self.free_mask(name).flatten(order="F")]

    def with_free_values(self, name: str, m: np.ndarray) -> StateSpace:
        """A copy with vec(M) = f + D·m."""
        f, D = self.design(name)
        shape = self.matrix(name).shape
        value = (f + D @ np.asarray(m, dtype=float)).reshape(shape, order="F")
        original = np.asarray(getattr(self, name))
        if name == "r":
            new_value: object = float(value[0, 0])
        elif original.ndim == 1:
            new_value = value[:, 0]
        else:
            new_value = value
        return self.copy(**{name: new_value})

    # -- initial-state covariance -------------------------------------------------------------------------
    def steady_prediction_covariance(self) -> np.ndarray:
        """P̄, the fixed point of P = Φ(P − PHᵀF⁻¹HP)Φᵀ + Q, F = HPHᵀ + R (cached)."""
        key = (self.phi.tobytes(), self.q.tobytes(), self.h.tobytes(), float(self.r))
        cached = self._steady_cache.get("value")
        if cached is None or cached[0] != key:
            guess = cached[1] if cached is not None else self._steady_cache.get("guess")
            value = steady_prediction_covariance(self.phi, self.q, self.h, self.r, guess=guess)
            self._steady_cache.clear()
            self._steady_cache["value"] = (key, value)
        return self._steady_cache["value"][1]

    def initial_covariance(self) -> np.ndarray:
        """Σ = cov(x_1): P̄ in ``'steady'`` mode, the stored Σ in ``'fixed'`` mode."""
        return self.steady_prediction_covariance() if self.sigma_mode == "steady" else self.sigma

    def check(self) -> None:
        """Raise InputError on non-finite or invalid matrices (negative variances, R ≤ 0 with no state noise)."""
        for name in ("phi", "q", "h", "u", "mu", "sigma", "b"):
            if not np.all(np.isfinite(getattr(self, name))):
                raise InputError(f"state-space matrix {name} has non-finite elements")
        if not np.isfinite(self.r) or self.r < 0:
            raise InputError(f"measurement-noise variance R must be finite and >= 0, got {self.r!r}")
        if np.any(np.diag(self.q) < 0):
            raise InputError("process-noise variances (diagonal of Q) must be >= 0")
        if self.sinusoid_omega and len(self.sinusoid_omega) != self.n_regressors:
            raise InputError(f"sinusoid_omega needs one value per regressor ({self.n_regressors}), got "
                             f"{len(self.sinusoid_omega)}")


def _fixed_initial_covariance(blk: StateBlock, r: float) -> np.ndarray:
    """Σ of a block in ``'fixed'`` mode: its stationary covariance when stable, else 1e-12·R (RW)."""
    if np.max(np.abs(np.linalg.eigvals(blk.phi))) < 1.0:
        n = blk.n_states
        p = np.linalg.solve(np.eye(n * n) - np.kron(blk.phi, blk.phi), blk.q.ravel()).reshape(n, n)
        return 0.5 * (p + p.T)
    return np.eye(blk.n_states) * 1e-12 * r


def validate_structure(names: list[str]) -> None:
    """InputError unless the structure is identifiable: one WN; at most one QN, RW, RR, LPF, DLPF, MA, BI."""
    if names.count("WN") != 1:
        raise InputError(f"model {'+'.join(names) or '(empty)'} needs exactly one WN component (white noise)")
    for single in ("QN", "RW", "RR", "LPF", "DLPF", "MA", "BI"):
        if names.count(single) > 1:
            raise InputError(f"model {'+'.join(names)} has {single} more than once; it is not identifiable")


@functools.lru_cache(maxsize=256)
def component_block(component: Component, dt: float) -> StateBlock:
    """``component.block(dt)``, cached (components are frozen); the arrays are shared and read-only."""
    block = component.block(dt)
    for value in vars(block).values():
        if isinstance(value, np.ndarray):
            value.flags.writeable = False
    return block


def state_span(states: tuple[int, ...]) -> slice:
    """The block's (consecutive) states as a slice; empty for a block without states (WN)."""
    return slice(states[0], states[-1] + 1) if states else slice(0, 0)


def from_components(
    components: list[Component],
    dt: float,
    *,
    intercept: bool = True,
    ramp: str = "measurement",
    exog_names: tuple[str, ...] = (),
    sigma_mode: str = "steady",
    sinusoid_omega: tuple[float, ...] = (),
) -> StateSpace:
    """Φ, Q, H, R, u, μ, Σ, b and their free masks from components (paper 000 eqs. 4–9).

    Parameters
    ----------
    components : one WN; at most one QN, RW, RR, LPF, DLPF, MA, BI; dt : sampling period [s]; intercept : a bias column
    ramp : RR as ``'measurement'`` (regressor ``t·dt``) or ``'state'`` (u = ω·dt into the RW or first GM state, §4.2)
    exog_names : further regressor columns; sigma_mode : ``'steady'`` or ``'fixed'``; sinusoid_omega : see StateSpace

    Raises InputError on an unidentifiable structure or an unknown ``ramp`` or ``sigma_mode``.
    """
    validate_structure([c.name for c in components])
    if ramp not in ("measurement", "state"):
        raise InputError(f"ramp must be 'measurement' or 'state', got {ramp!r}")
    if sigma_mode not in ("steady", "fixed"):
        raise InputError(f"sigma_mode must be 'steady' or 'fixed', got {sigma_mode!r}")
    blocks_of = {i: component_block(c, dt) for i, c in enumerate(components) if not isinstance(c, (WN, RR))}
    p = sum(blk.n_states for blk in blocks_of.values())
    phi, q = np.zeros((p, p)), np.zeros((p, p))
    phi_free, q_free = np.zeros((p, p), bool), np.zeros((p, p), bool)
    h, u, u_free = np.zeros(p), np.zeros(p), np.zeros(p, bool)
    sigma = np.zeros((p, p))
    r = 0.0
    regressors: list[str] = ["bias"] if intercept else []
    b_values: list[float] = [0.0] if intercept else []
    info: list[BlockInfo] = []
    start = 0
    state_of: dict[int, tuple[int, ...]] = {}
    for k, c in enumerate(components):
        if isinstance(c, WN):
            r = component_block(c, dt).r
            continue
        if isinstance(c, RR):
            continue
        blk = blocks_of[k]
        sl = slice(start, start + blk.n_states)
        phi[sl, sl], q[sl, sl] = blk.phi, blk.q
        phi_free[sl, sl], q_free[sl, sl] = blk.phi_free, blk.q_free
        h[sl] = blk.h
        state_of[k] = tuple(range(sl.start, sl.stop))
        start = sl.stop
    for k, c in enumerate(components):
        if isinstance(c, RR):
            if ramp == "measurement":
                regressors.append("ramp")
                b_values.append(c.slope)
                info.append(BlockInfo("RR", regressor=len(regressors) - 1))
            else:
                target = next((i for i, c2 in enumerate(components) if isinstance(c2, RW)), None)
                if target is None:
                    target = next((i for i, c2 in enumerate(components) if isinstance(c2, GM)), None)
                if target is None:
                    raise InputError("RR in state mode needs an RW or GM state for its input u to enter")
                j = state_of[target][0]
                u[j], u_free[j] = c.slope * dt, True
                info.append(BlockInfo("RR", input_state=j))
        else:
            info.append(BlockInfo(c.name, states=state_of.get(k, ())))
    for k, blk in blocks_of.items():
        span = state_span(state_of[k])
        sigma[span, span] = _fixed_initial_covariance(blk, r)
    regressors.extend(exog_names)
    b_values.extend([0.0] * len(exog_names))
    model = StateSpace(
        phi=phi, q=q, h=h, r=r, u=u, mu=np.zeros(p), sigma=sigma, b=np.array(b_values, dtype=float),
        phi_free=phi_free, q_free=q_free, h_free=np.zeros(p, bool), r_free=True, u_free=u_free,
        mu_free=np.zeros(p, bool), b_free=np.ones(len(b_values), bool), dt=float(dt), blocks=tuple(info),
        regressors=tuple(regressors), sigma_mode=sigma_mode, sinusoid_omega=tuple(sinusoid_omega),
    )
    model.check()
    return model


def with_components(model: StateSpace, components: list[Component]) -> StateSpace:
    """A copy of ``model`` with Φ, Q, R (and RR's slope) from ``components`` (same structure and order)."""
    if [c.name for c in components] != [blk.name for blk in model.blocks]:
        raise InputError("components do not match the model's structure")
    out = model.copy()
    for c, blk in zip(components, model.blocks, strict=True):
        if isinstance(c, WN):
            out.r = component_block(c, model.dt).r
        elif isinstance(c, RR):
            if blk.regressor is not None:
                out.b[blk.regressor] = c.slope
            else:
                out.u[blk.input_state] = c.slope * model.dt
        else:
            sb = component_block(c, model.dt)
            span = state_span(blk.states)
            out.phi[span, span] = sb.phi
            out.q[span, span] = sb.q
    return out


def _ramp(model: StateSpace, blk: BlockInfo) -> RR:
    slope = model.b[blk.regressor] if blk.regressor is not None else model.u[blk.input_state] / model.dt
    return RR(float(slope))


def ramp_components(model: StateSpace) -> dict[int, RR]:
    """The RR components of ``model`` by block position (for ``Parameterisation.to_components``)."""
    return {k: _ramp(model, blk) for k, blk in enumerate(model.blocks) if blk.name == "RR"}


def to_components(model: StateSpace) -> list[Component]:
    """Fitted continuous-time components of ``model``, in the order it was assembled from."""
    dt = model.dt
    out: list[Component] = []
    for blk in model.blocks:
        if blk.name == "WN":
            out.append(WN.from_per_sample(dt, sigma2_wn=max(float(model.r), 0.0)))
        elif blk.name == "RR":
            out.append(_ramp(model, blk))
        else:
            span = state_span(blk.states)
            out.append(COMPONENT_TYPES[blk.name].from_block(model.phi[span, span].copy(), model.q[span, span].copy(),
                                                            dt))
    return out
