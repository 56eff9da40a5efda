"""Paper 004 (Moghe, Zanetti, Akella) written out literally: the two-axis turntable CMKF with full matrices.

A test and benchmark reference, not part of the package: ``test/test_cmkf.py`` imports it (the test folder is on
``sys.path`` under pytest) and ``bench/bench_cmkf_paper.py`` adds ``test/`` to ``sys.path`` to import it.

The reference (6 states ``[r_x, v_x, b_x, r_y, v_y, b_y]``, 4 measurements, the 8×6 M_o of eq. 29, joint least
squares for (S_vx, S_vy)) :class:`imu_noise_id.core.cmkf.axis.AxisCmkf` and
:class:`imu_noise_id.core.cmkf.robot.RobotCmkf` are tested against, and the
Simulations section's turntable (:func:`simulate_turntable`). Equations: truth (6), (7), (9)–(12); propagation
(17), (23) with Q̂_a = Ĝ diag(Ŝ_v T) Ĝᵀ; Joseph update (24)–(27); estimator (28)–(35) (as in
:mod:`imu_noise_id.core.cmkf.stacked`); the joint positive-definiteness check of Q̂_a with fallback to the last
positive-definite estimate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import block_diag

from imu_noise_id.core.cmkf.axis import AxisCmkf, paper_interval


@dataclass(frozen=True)
class TurntableConfig:
    """Paper 004's simulation parameters and our turntable profile (the paper shows it only in fig. 1): the sensor on a
    circle of ``radius`` [m] at ``omega`` [rad/s], not rotating, a = −radius·ω²·(cos ωt, sin ωt), held at its interval
    average a_k = (v(t_{k+1}) − v(t_k))/T (truth model (6))."""

    T: float = 0.1
    tau: float = 3600.0
    S_v: float = 1e-6
    q_b: float = 5.55e-11
    R_diag: tuple[float, float, float, float] = (1e-8, 1e-6, 1e-8, 1e-6)
    S_v0: float = 2e-6
    radius: float = 0.5
    omega: float = 2.0 * np.pi / 10.0

    @property
    def sigma_ss(self) -> float:
        """Steady-state bias σ [m/s²] from Q_b = (1 − e^{−2T/τ}) σ² (eq. 7)."""
        return float(np.sqrt(self.q_b / (1.0 - np.exp(-2.0 * self.T / self.tau))))


def paper_matrices(T: float, tau: float) -> dict[str, np.ndarray]:
    """F (6), F̂, Ĝ (17), H (8), Λ of paper 004 for two axes, state ``[r_x, v_x, b_x, r_y, v_y, b_y]``."""
    phi = np.exp(-T / tau)
    F1 = np.array([[1.0, T, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, phi]])
    Fh1 = np.array([[1.0, T, -(T**2) / 2.0], [0.0, 1.0, -T], [0.0, 0.0, phi]])
    G1 = np.array([[T / 2.0], [1.0], [0.0]])
    H1 = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    L1 = np.array([[0.0], [0.0], [1.0]])
    return {
        "F": block_diag(F1, F1),
        "Fhat": block_diag(Fh1, Fh1),
        "Ghat": block_diag(G1, G1),
        "G": block_diag(G1 * T, G1 * T),  # G a_k = Ĝ Δv_k with Δv = a T (eq. 6, 18)
        "H": block_diag(H1, H1),
        "Lam": block_diag(L1, L1),
    }


class PaperCmkf:
    """Paper 004's CMKF for the two-axis turntable (full-matrix reference implementation).

    Parameters
    ----------
    T : sample time [s]; tau : bias time constants [s]; q_b : bias drive variance (eq. 7) [m²/s⁴]; R : (4, 4)
    measurement covariance; S_v0 : initial Ŝ_v [m²/s³]; x0, P0 : initial estimate; pd_check : ``"joint"`` (paper)
    or ``"per_axis"``; min_samples : stacked samples before Ŝ_v is used.

    Attributes as :class:`imu_noise_id.core.cmkf.protocol.CmkfFilter`: ``x`` (6,), ``P``, ``y`` (4,), ``S``,
    ``S_used`` (2,), ``S_ls``, ``count``; ``predict`` takes Δṽ, ``update`` the measurement.
    """

    def __init__(
        self,
        T: float,
        tau: float,
        q_b: float,
        R: np.ndarray,
        S_v0: float,
        *,
        x0: np.ndarray,
        P0: np.ndarray,
        pd_check: str = "joint",
        min_samples: int = 1,
    ) -> None:
        self.T = float(T)
        mats = paper_matrices(T, tau)
        self.Fh, self.Gh, self.H, self.Lam = mats["Fhat"], mats["Ghat"], mats["H"], mats["Lam"]
        self.R = np.asarray(R, dtype=float)
        self.Qb = q_b * np.eye(2)
        self.S_used = np.array([S_v0, S_v0], dtype=float)
        self.x = np.asarray(x0, dtype=float).copy()
        self.P = np.asarray(P0, dtype=float).copy()
        self.y = np.full(4, np.nan)
        self.S = np.full((4, 4), np.nan)
        self.pd_check = pd_check
        self.min_samples = int(min_samples)
        # Stacked-estimator constants (eqs. 29–35).
        H, Fh, Gh, Lam = self.H, self.Fh, self.Gh, self.Lam
        self.Mo = np.vstack([H @ Fh, H])
        self.Mo_pinv = np.linalg.pinv(self.Mo)
        self.Mv = np.vstack([H, np.zeros_like(H)])
        self.Ma = np.vstack([H @ Gh, np.zeros_like(H @ Gh)])
        self.Mw = np.vstack([H @ Lam, np.zeros_like(H @ Lam)])
        Mp = self.Mo_pinv
        self.A1 = -Mp @ self.Mv
        self.A2 = Fh @ Mp @ self.Mv - np.eye(6)
        B1 = Mp @ self.Mw
        B2 = Lam - Fh @ Mp @ self.Mw
        self.cov_W = B1 @ self.Qb @ B1.T + B2 @ self.Qb @ B2.T
        E1 = Mp[:, :4]
        E2 = Mp[:, 4:] - Fh @ Mp[:, :4]
        E3 = -Fh @ Mp[:, 4:]
        self.cov_E = E1 @ self.R @ E1.T + E2 @ self.R @ E2.T + E3 @ self.R @ E3.T
        self.D = [self._qa_basis(i) for i in range(2)]
        self.N = np.array([[np.sum(Di * Dj) for Dj in self.D] for Di in self.D])
        self.sum_ZZ = np.zeros((6, 6))
        self.count = 0
        self._z_hist: list[np.ndarray] = []
        self._dv_hist: list[np.ndarray] = []
        self.S_ls = np.full(2, np.nan)

    def _qa_basis(self, axis: int) -> np.ndarray:
        """A₁ Q_a A₁ᵀ + A₂ Q_a A₂ᵀ for S_v = 1 on ``axis`` (eq. 35)."""
        e = np.zeros(2)
        e[axis] = self.T
        Qa = self.Gh @ np.diag(e) @ self.Gh.T
        return self.A1 @ Qa @ self.A1.T + self.A2 @ Qa @ self.A2.T

    @property
    def Q_a(self) -> np.ndarray:
        """Q̂_a = Ĝ diag(Ŝ_v T) Ĝᵀ used in eq. (23)."""
        return self.Gh @ np.diag(self.S_used * self.T) @ self.Gh.T

    def predict(self, dv: np.ndarray) -> None:
        """Eqs. (17) and (23) with the accelerometer increment Δṽ_k (2,) [m/s]."""
        self.x = self.Fh @ self.x + self.Gh @ dv
        self.P = self.Fh @ self.P @ self.Fh.T + self.Q_a + self.Lam @ self.Qb @ self.Lam.T
        self._dv_hist = [*self._dv_hist[-1:], np.asarray(dv, dtype=float)]

    def update(self, z: np.ndarray) -> float:
        """Eqs. (24)–(27), then the covariance estimator (28)–(35); returns the NIS (4 dof)."""
        H, R = self.H, self.R
        S = H @ self.P @ H.T + R
        K = self.P @ H.T @ np.linalg.inv(S)
        nu = z - H @ self.x
        self.y, self.S = nu, S
        self.x = self.x + K @ nu
        IKH = np.eye(6) - K @ H
        self.P = IKH @ self.P @ IKH.T + K @ R @ K.T
        self._z_hist = [*self._z_hist[-2:], np.asarray(z, dtype=float)]
        if len(self._z_hist) == 3 and len(self._dv_hist) == 2:
            self._estimate()
        return float(nu @ np.linalg.solve(S, nu))

    def stacked_sample(self) -> np.ndarray:
        """𝒵_k = M_o† 𝒴_k − F̂ M_o† 𝒴_{k−1} − Ĝ Δṽ_{k−2} (eqs. 30, 33) from the last three epochs."""
        z2, z1, z0 = self._z_hist
        dv2, dv1 = self._dv_hist
        Yk = np.concatenate([z0, z1]) - self.Ma @ dv1
        Yk1 = np.concatenate([z1, z2]) - self.Ma @ dv2
        return self.Mo_pinv @ Yk - self.Fh @ self.Mo_pinv @ Yk1 - self.Gh @ dv2

    def _estimate(self) -> None:
        Z = self.stacked_sample()
        self.sum_ZZ += np.outer(Z, Z)
        self.count += 1
        C = self.sum_ZZ / self.count - self.cov_W - self.cov_E
        rhs = np.array([np.sum(C * Di) for Di in self.D])
        self.S_ls = np.linalg.solve(self.N, rhs)
        if self.count < self.min_samples:
            return
        ok = self.S_ls > 0  # Q̂_a = Ĝ diag(S_v T) Ĝᵀ is positive (semi-)definite iff every S_v > 0
        if self.pd_check == "joint":
            if ok.all():
                self.S_used = self.S_ls.copy()
        else:
            self.S_used = np.where(ok, self.S_ls, self.S_used)

    def cov_Z_model(self, S_v: np.ndarray) -> np.ndarray:
        """Cov(𝒵) of eqs. (34)–(35) for the PSDs ``S_v`` (2,)."""
        return self.cov_W + S_v[0] * self.D[0] + S_v[1] * self.D[1] + self.cov_E


@dataclass
class TurntableRun:
    """One simulated turntable run: true states, accelerometer increments and measurements."""

    t: np.ndarray  # (K+1,) s
    x: np.ndarray  # (K+1, 6) true [r_x, v_x, b_x, r_y, v_y, b_y]
    dv: np.ndarray  # (K, 2) accelerometer Δṽ_k over [t_k, t_{k+1}] [m/s]
    z: np.ndarray  # (K+1, 4) measurements (eq. 8)
    accel: np.ndarray  # (K, 2) true acceleration a_k [m/s²]


def simulate_turntable(cfg: TurntableConfig, duration: float, rng: np.random.Generator) -> TurntableRun:
    """Simulate paper 004's revolving table, eqs. (6), (7), (8), (12): K = round(duration / T) accelerometer samples and
    K + 1 measurements."""
    T = cfg.T
    K = round(duration / T)
    mats = paper_matrices(T, cfg.tau)
    F, G, H, Lam = mats["F"], mats["G"], mats["H"], mats["Lam"]
    t = np.arange(K + 1) * T
    w = cfg.omega
    vel = cfg.radius * w * np.column_stack([-np.sin(w * t), np.cos(w * t)])
    accel = np.diff(vel, axis=0) / T
    sig = cfg.sigma_ss
    x = np.zeros((K + 1, 6))
    x[0] = [cfg.radius, 0.0, rng.normal(0, sig), 0.0, cfg.radius * w, rng.normal(0, sig)]
    wb = rng.normal(0.0, np.sqrt(cfg.q_b), size=(K, 2))
    for k in range(K):
        x[k + 1] = F @ x[k] + G @ accel[k] + Lam @ wb[k]
    bias = x[:-1][:, [2, 5]]
    dv = accel * T + bias * T + rng.normal(0.0, np.sqrt(cfg.S_v * T), size=(K, 2))
    eta = rng.normal(0.0, 1.0, size=(K + 1, 4)) * np.sqrt(np.asarray(cfg.R_diag))
    z = x @ H.T + eta
    return TurntableRun(t, x, dv, z, accel)


@dataclass
class TurntableMonteCarlo:
    """Batched Monte-Carlo time series of the CMKF on the turntable (axes run-major: x, y).

    Attributes
    ----------
    t : (J,) recorded steps [s]
    err : (runs, J, 2, 3) state error x − x̂ per axis after the update; P_diag : (runs, J, 2, 3)
    S_v : (runs, J, 2) Ŝ_v in use; nees : (runs, J) NEES (6 dof)
    accel_err : (runs, J, 2) a_k − (Δṽ_k/T − b̂_k) (paper fig. 5)
    rejected_steps : steps at which the positive-definiteness check refused some run's new Ŝ_v
    """

    t: np.ndarray
    err: np.ndarray
    P_diag: np.ndarray
    S_v: np.ndarray
    nees: np.ndarray
    accel_err: np.ndarray
    rejected_steps: int = 0


def simulate_turntable_batch(
    cfg: TurntableConfig, duration: float, n_runs: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Vectorised version of :func:`simulate_turntable` for ``n_runs`` runs: (x, dv, z, accel) arrays."""
    from scipy.signal import lfilter

    T = cfg.T
    K = round(duration / T)
    t = np.arange(K + 1) * T
    w = cfg.omega
    vel = cfg.radius * w * np.column_stack([-np.sin(w * t), np.cos(w * t)])
    accel = np.diff(vel, axis=0) / T
    pos = np.vstack([[cfg.radius, 0.0], cfg.radius + np.zeros((K, 2))])
    pos[1:] = np.array([cfg.radius, 0.0]) + np.cumsum(vel[:-1] * T + accel * T**2 / 2, axis=0)
    phi = np.exp(-T / cfg.tau)
    drive = rng.normal(0.0, np.sqrt(cfg.q_b), size=(n_runs, K, 2))
    b0 = rng.normal(0.0, cfg.sigma_ss, size=(n_runs, 1, 2))
    bias = np.concatenate([b0, np.zeros((n_runs, K, 2))], axis=1)
    bias[:, 1:] = lfilter([1.0], [1.0, -phi], drive, axis=1) + b0 * phi ** np.arange(1, K + 1)[None, :, None]
    x = np.zeros((n_runs, K + 1, 2, 3))
    x[..., 0] = pos
    x[..., 1] = vel
    x[..., 2] = bias
    dv = accel * T + bias[:, :-1] * T + rng.normal(0.0, np.sqrt(cfg.S_v * T), size=(n_runs, K, 2))
    z = x[..., :2] + rng.normal(0.0, 1.0, size=(n_runs, K + 1, 2, 2)) * np.sqrt(np.asarray(cfg.R_diag)).reshape(2, 2)
    return x, dv, z, accel


def turntable_monte_carlo(
    cfg: TurntableConfig,
    duration: float,
    n_runs: int,
    rng: np.random.Generator,
    *,
    pd_check: str = "joint",
    min_samples: int = 1,
    record_every: int = 1,
) -> TurntableMonteCarlo:
    """Paper 004's CMKF (batched :class:`AxisCmkf`) on ``n_runs`` simulated runs: x̂₀ = [z_r, z_v, 0],
    P₀ = diag(R_r, R_v, σ_ss²) per axis, the Ŝ_v check joint over each run's two axes; stored every
    ``record_every`` steps."""
    x, dv, z, accel = simulate_turntable_batch(cfg, duration, n_runs, rng)
    K = dv.shape[1]
    n = 2 * n_runs
    Rax = np.diag(cfg.R_diag[:2])
    filt = AxisCmkf(n, cfg.S_v0, mode="pos_vel", pd_check=pd_check, min_samples=min_samples, pd_group=2)
    x0 = np.zeros((n, 3))
    x0[:, :2] = z[:, 0].reshape(n, 2)
    P0 = np.broadcast_to(np.diag([cfg.R_diag[0], cfg.R_diag[1], cfg.sigma_ss**2]), (n, 3, 3))
    filt.initialise(x0, P0)
    iv = paper_interval(cfg.T, cfg.tau, cfg.sigma_ss)
    G = np.array([cfg.T / 2.0, 1.0, 0.0])
    R = np.broadcast_to(Rax, (n, 2, 2))
    steps = np.arange(0, K + 1, record_every)
    err = np.zeros((n_runs, steps.size, 2, 3))
    Pd = np.zeros((n_runs, steps.size, 2, 3))
    Sv = np.zeros((n_runs, steps.size, 2))
    nees = np.zeros((n_runs, steps.size))
    aerr = np.zeros((n_runs, steps.size, 2))

    def record(k: int) -> None:
        j = k // record_every
        e = x[:, k].reshape(n, 3) - filt.x
        err[:, j] = e.reshape(n_runs, 2, 3)
        Pd[:, j] = np.diagonal(filt.P, axis1=1, axis2=2).reshape(n_runs, 2, 3)
        Sv[:, j] = filt.S_used.reshape(n_runs, 2)
        nees[:, j] = np.einsum("ni,ni->n", e, np.linalg.solve(filt.P, e[..., None])[..., 0]).reshape(n_runs, 2).sum(1)
        if k < K:
            aerr[:, j] = accel[k] - (dv[:, k] / cfg.T - filt.x[:, 2].reshape(n_runs, 2))

    for k in range(K):
        if k % record_every == 0:
            record(k)
        d = dv[:, k].reshape(n)
        filt.predict(filt.x @ iv.Phi.T + d[:, None] * G, iv)
        filt.update(z[:, k + 1].reshape(n, 2), R)
    if K % record_every == 0:
        record(K)
    return TurntableMonteCarlo(steps * cfg.T, err, Pd, Sv, nees, aerr, filt.rejected)

