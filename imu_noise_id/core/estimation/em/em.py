"""Constrained EM for state-space error models (paper 000, Stebler et al. 2011, §3): E-step by the Kalman smoother
(:class:`Sums`), M-step by the closed-form updates of §3.3 for u, μ, Φ, H, Q, R with vec(M) = f + D·m (eqs. 7–9), in
sequence (ECM), Σ fixed. Beyond the paper: regressors b updated like H; the Q update's S with Φ x̄ uᵀ + u x̄ᵀ Φᵀ (the
paper prints Φ x_{t−1}^N uᵀ Φᵀ); Σ = P̄(θ) in steady mode (a generalised EM); the gradient :class:`MatrixScore`."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ... import kalman
from ...errors import InputError
from ...kalman import riccati
from ...kalman.common import check_data
from ...kalman.statespace import StateSpace, state_span
from ...noise.components import PHI_RANGE

#: Floor of free process-noise variances relative to R (keeps Q invertible in the Φ and u updates).
Q_FLOOR_REL = 1e-20


@dataclass
class Sums:
    """Expected sufficient statistics of one E-step (paper 000 §3.3, P̃_t = P_t^N + x_t^N x_t^{Nᵀ})."""

    n: int
    n_obs: int
    s11: np.ndarray  # Σ_{t=2}^{N} P̃_t
    s00: np.ndarray  # Σ_{t=2}^{N} P̃_{t−1}
    s10: np.ndarray  # Σ_{t=2}^{N} P̃_{t,t−1}
    x_next: np.ndarray  # Σ_{t=2}^{N} x_t^N
    x_prev: np.ndarray  # Σ_{t=2}^{N} x_{t−1}^N
    x1: np.ndarray  # x_1^N
    p1: np.ndarray  # P_1^N
    pt_obs: np.ndarray  # Σ_obs P̃_t
    yx_obs: np.ndarray  # Σ_obs y_t x_t^N
    zx_obs: np.ndarray  # Σ_obs z_t x_t^{Nᵀ}  (k, p)
    zz_obs: np.ndarray  # Σ_obs z_t z_tᵀ
    zy_obs: np.ndarray  # Σ_obs z_t y_t
    yy_obs: float  # Σ_obs y_t²
    loglik: float  # exact log-likelihood at the E-step's θ


@dataclass(frozen=True)
class DataSums:
    """Sums of the data alone (the same at every E-step): the observed samples' count, Σ_obs z zᵀ, Σ_obs z y and
    Σ_obs y²."""

    n_obs: int
    zz: np.ndarray
    zy: np.ndarray
    yy: float

    @classmethod
    def of(cls, y: np.ndarray, z: np.ndarray) -> DataSums:
        obs = ~np.isnan(y)
        allo = bool(np.all(obs))
        yo = y if allo else y[obs]
        zt = np.ascontiguousarray((z if allo else z[obs]).T)
        return cls(yo.size, zt @ zt.T, zt @ yo, float(yo @ yo))


def sums_from_stats(st: kalman.SmootherStats, data: DataSums) -> Sums:
    """Reduce smoother output to :class:`Sums` (paper 000 §3.3: P̃_t = P_t^N + x_t^N x_t^{Nᵀ}); ValueError if it ran
    without the p × p sums (``moments=False``)."""
    x = st.states
    if x.gram is None or x.gram_obs is None or x.lag is None:
        raise ValueError("the smoother ran without the p x p sums of its means (moments=False): no M-step from it")
    s11 = x.gram - np.outer(x.first, x.first) + st.sum_p - st.p_first
    s00 = x.gram - np.outer(x.last, x.last) + st.sum_p - st.p_last
    return Sums(
        n=st.observed.size, n_obs=data.n_obs, s11=s11, s00=s00, s10=x.lag + st.sum_lag,
        x_next=x.total - x.first, x_prev=x.total - x.last, x1=x.first.copy(), p1=st.p_first,
        pt_obs=x.gram_obs + st.sum_p_obs, yx_obs=x.y_cross, zx_obs=x.z_cross, zz_obs=data.zz, zy_obs=data.zy,
        yy_obs=data.yy, loglik=st.loglik,
    )


def estep(
    model: StateSpace, y: np.ndarray, z: np.ndarray, engine: str = "auto", data: DataSums | None = None
) -> Sums:
    """Run the smoother and reduce its output to :class:`Sums` (``data``: precomputed :class:`DataSums`)."""
    st = kalman.smooth(model, y, z, engine=engine)
    return sums_from_stats(st, data or DataSums.of(y, z))


def _pinv_psd(m: np.ndarray) -> np.ndarray:
    return np.linalg.pinv(m, hermitian=True)


def _measurement_sse(model: StateSpace, s: Sums) -> float:
    """W = Σ_obs [(y_t − H x_t^N − b z_t)² + H P_t^N Hᵀ] from the sums."""
    h, b = model.h, model.b
    # E[(y − Hx − bz)²] summed: y² − 2 y Hx − 2 y bz + H P̃ H + 2 (bz)(Hx) + (bz)²
    return float(
        s.yy_obs - 2.0 * h @ s.yx_obs - 2.0 * b @ s.zy_obs + h @ s.pt_obs @ h
        + 2.0 * b @ s.zx_obs @ h + b @ s.zz_obs @ b
    )


def smoothed_measurement_sse(model: StateSpace, stats: kalman.SmootherStats) -> float:
    """:func:`_measurement_sse` from the smoother's output: Σ_obs (y_t − H x_t^N − b z_t)² + H (Σ_obs P_t^N) Hᵀ, the
    residuals formed sample by sample by the smoother (:attr:`~..kalman.StateSums.residual_sse`, at the model's b;
    O(pN), no p × p sums of x_t^N x_t^{Nᵀ} and no cancellation between them)."""
    h = model.h
    return float(stats.states.residual_sse + h @ stats.sum_p_obs @ h)


def mstep(model: StateSpace, s: Sums) -> StateSpace:
    """One sweep of the constrained updates of paper 000 §3.3 (u, μ, Φ, H, Q, then b and R); free diagonal Φ clipped
    to ``PHI_RANGE``, free Q variances ≥ :data:`Q_FLOOR_REL`·R."""
    m = model.copy()
    n1 = s.n - 1
    p = m.n_states
    q_inv = _pinv_psd(m.q) if p else np.zeros((0, 0))
    if np.any(m.u_free):  # u update
        f, D = m.design("u")
        rhs = s.x_next - m.phi @ s.x_prev - n1 * f
        m_u = np.linalg.solve(D.T @ q_inv @ D, D.T @ q_inv @ rhs) / n1
        m = m.with_free_values("u", m_u)
    if np.any(m.mu_free):  # μ update
        sig_inv = _pinv_psd(m.initial_covariance())
        f, D = m.design("mu")
        m_mu = np.linalg.solve(D.T @ sig_inv @ D, D.T @ sig_inv @ (s.x1 - f))
        m = m.with_free_values("mu", m_mu)
    if np.any(m.phi_free):  # Φ update
        f, D = m.design("phi")
        kron = np.kron(s.s00, q_inv)
        rhs = (q_inv @ s.s10).flatten(order="F") - kron @ f - (q_inv @ np.outer(m.u, s.x_prev)).flatten(order="F")
        m_phi = np.linalg.solve(D.T @ kron @ D, D.T @ rhs)
        m = m.with_free_values("phi", m_phi)
        idx = np.flatnonzero(np.diag(m.phi_free))
        m.phi[idx, idx] = np.clip(m.phi[idx, idx], *PHI_RANGE)
    if np.any(m.h_free):  # H update (l = 1: R⁻¹ is a scalar)
        f, D = m.design("h")
        yx = s.yx_obs - m.b @ s.zx_obs
        rhs = yx / m.r - (s.pt_obs / m.r) @ f
        m_h = np.linalg.solve(D.T @ (s.pt_obs / m.r) @ D, D.T @ rhs)
        m = m.with_free_values("h", m_h)
    if np.any(m.q_free):  # Q update
        S = transition_residual(s, m.phi, m.u)
        f, D = m.design("q")
        m_q = np.linalg.solve(D.T @ D, D.T @ S.flatten(order="F")) / n1
        m = m.with_free_values("q", m_q)
        idx = np.flatnonzero(np.diag(m.q_free))
        m.q[idx, idx] = np.maximum(m.q[idx, idx], Q_FLOOR_REL * max(m.r, 1e-300))
    if np.any(m.b_free):  # regression coefficients (beyond the paper; closed form like H)
        free = np.asarray(m.b_free, bool)
        b_fix = np.where(free, 0.0, m.b)
        rhs = s.zy_obs - s.zx_obs @ m.h - s.zz_obs @ b_fix
        m.b[free] = np.linalg.solve(s.zz_obs[np.ix_(free, free)], rhs[free])
    if m.r_free:  # R update
        m.r = max(_measurement_sse(m, s) / s.n_obs, 1e-300)
    return m


def transition_residual(s: Sums, phi: np.ndarray, u: np.ndarray) -> np.ndarray:
    """S(Φ, u) = Σ_{t=2}^N E[(x_t − Φ x_{t−1} − u)(…)ᵀ] from the E-step sums (paper 000 §3.3; the Q update's S, and
    the Q term of :class:`MatrixScore`)."""
    n1 = s.n - 1
    return (s.s11 - s.s10 @ phi.T - phi @ s.s10.T + phi @ s.s00 @ phi.T
            - np.outer(s.x_next, u) - np.outer(u, s.x_next)
            + np.outer(phi @ s.x_prev, u) + np.outer(u, phi @ s.x_prev) + n1 * np.outer(u, u))


def _component_spans(model: StateSpace) -> list[slice]:
    """The states of each component of ``model`` with states (all states as one span for a model without blocks)."""
    spans = [state_span(b.states) for b in model.blocks if b.states]
    return spans or [slice(0, model.n_states)]


@dataclass(frozen=True)
class MatrixScore:
    """Gradient of the exact log-likelihood in Φ, Q, R at the E-step's θ_E by Fisher's identity (beyond paper 000):
    ∂ℓ/∂θ = ∂Q(θ | θ_E)/∂θ at θ_E, with Q the expected complete-data log-likelihood of §3.3,

        Q = −½(N_obs ln 2πR + W/R) − ½((N−1) ln det Q + tr(Q⁻¹ S(Φ, u))) − ½(ln det Σ + tr(Σ⁻¹ E₁)),
        ∂Q/∂R = −½(N_obs/R − W/R²),   ∂Q/∂Q = ½ Σ_t (r_t r_tᵀ − N_t),   ∂Q/∂Φ = Σ_t (r_t (x_t^N)ᵀ − N_t L_t P_t)

    (W: :func:`_measurement_sse`; the Φ and Q terms, −½((N−1)Q⁻¹ − Q⁻¹ S Q⁻¹) and Q⁻¹ C with C = Σ E[η_t x_tᵀ],
    in the disturbance smoother's form of :class:`~imu_noise_id.core.kalman.common.DisturbanceSums`, E[η_t | y] = Q r_t
    (Koopman & Shephard 1992); E₁ = E[(x_1 − μ)(x_1 − μ)ᵀ], its steady-mode share by :class:`InitialTermGradient`).
    H is held fixed. Φ and Q are block-diagonal by component, and a parameter moves its own component's block only:
    :meth:`directional` reads those blocks, zero between components."""

    g_phi: np.ndarray
    g_q: np.ndarray
    g_r: float
    #: The x₁ term where its adjoint is not computed (:class:`DifferencedInitialTerm`), else None (in the g's or none)
    initial: DifferencedInitialTerm | None = None

    @classmethod
    def at(cls, model: StateSpace, stats: kalman.SmootherStats, data: DataSums) -> MatrixScore:
        """The gradient at θ_E's ``model`` from its smoother output ``stats`` on ``data``; ValueError when R = 0.
        Entries whose sums overflowed (a drive near zero) are NaN."""
        r = float(model.r)
        if not r * r > 0.0:  # a white noise driven to (numerically) zero beside a filter that carries it: no score
            raise ValueError("the white-noise variance is zero: the likelihood's gradient is not defined there")
        n_obs = data.n_obs
        g_r = -0.5 * (n_obs / r - smoothed_measurement_sse(model, stats) / r**2)
        p = model.n_states
        g_phi, g_q = np.zeros((p, p)), np.zeros((p, p))
        sums = stats.disturbances
        with np.errstate(over="ignore", invalid="ignore"):
            full_phi, full_q = sums.rx - sums.nlp, 0.5 * (sums.rr - sums.n)
        for span in _component_spans(model):  # Φ and Q are block-diagonal by component
            g_phi[span, span], g_q[span, span] = full_phi[span, span], full_q[span, span]
        initial = InitialTermGradient.at(model, stats.states.first, stats.p_first)
        if initial.sensitivity is not None:
            sens = initial.sensitivity
            g_phi, g_q, g_r = g_phi + sens.g_phi, g_q + sens.g_q, g_r + sens.g_r
        return cls(g_phi, g_q, g_r, initial.differenced)

    def directional(self, states: slice, dphi: np.ndarray, dq: np.ndarray, dr: float) -> float:
        """∂ℓ along a change dΦ, dQ of the block on ``states`` (the rest of Φ, Q unchanged) and dR."""
        out = float(np.vdot(self.g_phi[states, states], dphi) + np.vdot(self.g_q[states, states], dq)
                    + self.g_r * dr)
        return out + (self.initial.directional(states, dphi, dq, dr) if self.initial is not None else 0.0)


@dataclass(frozen=True)
class InitialTermGradient:
    """The x_1 term −½(log det Σ + tr(Σ⁻¹E₁)) of Q to first order around θ_E: in steady mode tr(W dP̄) with
    W = −½(Σ⁻¹ − Σ⁻¹E₁Σ⁻¹) (:class:`~imu_noise_id.core.kalman.riccati.SteadyCovarianceSensitivity`), or, where the
    closed loop has a pole within :data:`~imu_noise_id.core.kalman.riccati.UNIT_POLE_GAP` of 1 (a walk driven to ~0),
    :class:`DifferencedInitialTerm` (``differenced``); both None in fixed mode."""

    sensitivity: riccati.SteadyCovarianceSensitivity | None
    differenced: DifferencedInitialTerm | None = None

    @classmethod
    def at(cls, model: StateSpace, x1: np.ndarray, p1: np.ndarray) -> InitialTermGradient:
        """The linearisation at θ_E's ``model`` with its smoothed first state ``x1`` = x_1^N and ``p1`` = P_1^N."""
        if model.n_states == 0 or model.sigma_mode != "steady":
            return cls(None)
        sigma = model.initial_covariance()
        d1 = x1 - model.mu
        nz = np.diag(sigma) > 0
        e1 = p1 + np.outer(d1, d1)
        W = np.zeros_like(sigma)
        if np.any(nz):
            inv = np.linalg.inv(sigma[np.ix_(nz, nz)])
            with np.errstate(over="ignore", invalid="ignore"):  # Σ near singular: the sensitivity reads None
                W[np.ix_(nz, nz)] = -0.5 * (inv - inv @ e1[np.ix_(nz, nz)] @ inv)  # symmetrised by the Stein sum
        sensitivity = riccati.SteadyCovarianceSensitivity.of(model.phi, model.q, model.h, float(model.r), P=sigma, W=W)
        if sensitivity is not None or not np.any(nz):
            return cls(sensitivity)
        return cls(None, DifferencedInitialTerm(model.phi, model.q, model.h, float(model.r), sigma, e1, nz))


#: Step [in the log-parameters] of :class:`DifferencedInitialTerm`'s central differences.
INITIAL_TERM_STEP = 1e-4


@dataclass(frozen=True)
class DifferencedInitialTerm:
    """The x_1 term T = −½(log det Σ + tr(Σ⁻¹E₁)) on the states ``nz`` with E₁ held, its directional derivative by
    central differences of :data:`INITIAL_TERM_STEP` along (dΦ, dQ, dR), Σ = P̄ re-solved by the doubling
    (:func:`~imu_noise_id.core.kalman.riccati.steady_prediction_covariance`; Newton's Stein sums diverge at a pole
    that close to 1). Where the closed loop has a pole within 10⁻¹² of 1 the adjoint sum of
    :class:`InitialTermGradient` has ~10¹² terms; beside a GM as slow as a walk (τ 100 records) its entries reached
    10¹⁶⁰. Two Riccati solves per direction, O(p³) each, none over the samples."""

    phi: np.ndarray
    q: np.ndarray
    h: np.ndarray
    r: float
    sigma: np.ndarray
    e1: np.ndarray
    nz: np.ndarray

    def value(self, sigma: np.ndarray) -> float:
        """T at Σ = ``sigma``."""
        s = sigma[np.ix_(self.nz, self.nz)]
        _, logdet = np.linalg.slogdet(s)
        return -0.5 * (logdet + float(np.trace(np.linalg.solve(s, self.e1[np.ix_(self.nz, self.nz)]))))

    def directional(self, states: slice, dphi: np.ndarray, dq: np.ndarray, dr: float) -> float:
        """∂T along dΦ, dQ of the block on ``states`` and dR (per unit log-parameter)."""
        ends = []
        for t in (INITIAL_TERM_STEP, -INITIAL_TERM_STEP):
            phi, q = self.phi.copy(), self.q.copy()
            phi[states, states] += t * dphi
            q[states, states] += t * dq
            P = riccati.steady_prediction_covariance(phi, q, self.h, self.r + t * dr)  # Newton fails at a pole ≈ 1
            ends.append(self.value(P))
        return (ends[0] - ends[1]) / (2.0 * INITIAL_TERM_STEP)


@dataclass
class EMResult:
    """Outcome of :func:`run_em`: the last iterate ``model``; ``loglik``, the exact log-likelihood at θ⁽⁰⁾, θ⁽¹⁾, …
    (the last entry the final model's); ``n_iter`` M-steps; ``converged`` (stopping rule met); ``diverged`` (an
    update left the filter's domain, the last good iterate kept)."""

    model: StateSpace
    loglik: list[float] = field(default_factory=list)
    n_iter: int = 0
    converged: bool = False
    diverged: bool = False


def relative_change(l_new: float, l_old: float, c: float = 1.0) -> float:
    """Stopping statistic of paper 000 §3.5(ii): (L⁺ − L)/(0.5·|L⁺ + L| + c)."""
    return (l_new - l_old) / (0.5 * abs(l_new + l_old) + c)


def run_em(
    model: StateSpace,
    y: np.ndarray,
    z: np.ndarray | None = None,
    *,
    max_iter: int = 500,
    tol: float = 1e-9,
    c: float = 1.0,
    engine: str = "auto",
    initial: kalman.SmootherStats | None = None,
    final_estep: bool = True,
) -> EMResult:
    """Iterate E- and M-steps until the relative change of §3.5(ii) is below ``tol``; InputError on bad data or
    ``max_iter`` < 0.

    Parameters
    ----------
    model : initial θ⁽⁰⁾ with its free masks
    y, z : signal (N,) [u] (NaN = missing) and measurement regressors (N, k)
    max_iter, tol, c : iteration cap, threshold ε and constant c of the stopping rule
    engine : Kalman engine (``'auto'``, ``'steady'``, ``'exact'``)
    initial : smoother statistics of ``model`` on (y, z), when the caller has them (first E-step skipped)
    final_estep : ``False``: the ``max_iter``-th M-step's model is returned unscored (divergence not detected)
    """
    y, z = check_data(y, z, model.n_regressors)
    if max_iter < 0:
        raise InputError(f"max_iter must be >= 0, got {max_iter}")
    result = EMResult(model)
    data = DataSums.of(y, z)
    s = sums_from_stats(initial, data) if initial is not None else estep(model, y, z, engine, data)
    result.loglik.append(s.loglik)
    for it in range(max_iter):
        new = mstep(result.model, s)
        if not final_estep and it == max_iter - 1:
            result.model = new
            result.n_iter += 1
            break
        try:
            s = estep(new, y, z, engine, data)
        except (InputError, np.linalg.LinAlgError):
            # The update left the space where the filter exists (e.g. a GM pole at 1 next to an RW: an
            # unobservable pair). Paper 000 §3.5(iii) warns of such divergence; keep the last good iterate.
            result.diverged = True
            break
        result.model = new
        result.n_iter += 1
        result.loglik.append(s.loglik)
        if abs(relative_change(result.loglik[-1], result.loglik[-2], c)) < tol:
            result.converged = True
            break
    return result
