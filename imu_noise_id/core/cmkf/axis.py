"""Paper 004's CMKF for ``n`` independent axes on one time base, state ``[r, v, b]`` per axis (block diagonal):
x̂⁻ = F̂ x̂⁺ + U (17), P⁻ = F̂ P F̂ᵀ + Ŝ_v Qa1 + q_b ΛΛᵀ (23), Joseph update (24)–(27), :mod:`.stacked` (28)–(35) and
the Ŝ_v check; H of ``"pos_vel"`` (eq. 8) or ``"vel"`` (velocity, on the observable [v, b]; docs/cmkf.md)."""

from __future__ import annotations

import numpy as np

from .interval import ImuInterval
from .matching import MatchingLeastSquares
from .stacked import StackedSvEstimator

MODES = ("pos_vel", "vel")
PD_CHECKS = ("joint", "per_axis", "se_floor")


class AxisCmkf:
    """Batched per-axis CMKF, a :class:`~.protocol.CmkfFilter`: ``n_axes``, initial Ŝ_v ``s_v0`` (scalar or (n,))
    [m²/s³], ``mode`` ``"pos_vel"`` or ``"vel"``, ``pd_check`` ``"joint"`` (paper; all axes or groups of ``pd_group``),
    ``"per_axis"`` or ``"se_floor"``, ``min_samples`` before Ŝ_v is used; ValueError on invalid arguments."""

    def __init__(
        self,
        n_axes: int,
        s_v0: float | np.ndarray,
        *,
        mode: str = "pos_vel",
        pd_check: str = "joint",
        min_samples: int = 1,
        pd_group: int | None = None,
    ) -> None:
        if mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
        if pd_check not in PD_CHECKS:
            raise ValueError(f"pd_check must be one of {PD_CHECKS}, got {pd_check!r}")
        s_v0 = np.broadcast_to(np.asarray(s_v0, dtype=float), (n_axes,)).copy()
        if not np.all(np.isfinite(s_v0)) or np.any(s_v0 <= 0):
            raise ValueError(f"initial S_v must be finite and > 0, got {s_v0}")
        self.n = int(n_axes)
        self.mode = mode
        self.pd_check = pd_check
        self.min_samples = int(min_samples)
        self.pd_group = int(pd_group or n_axes)
        if self.n % self.pd_group:
            raise ValueError(f"pd_group={pd_group} does not divide n_axes={n_axes}")
        self.S_used = s_v0
        self.s_v0 = s_v0.copy()
        if mode == "pos_vel":
            self.H = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
            self.sub = slice(0, 3)
        else:
            self.H = np.array([[0.0, 1.0, 0.0]])
            self.sub = slice(1, 3)
        self.m = self.H.shape[0]
        self.estimator = StackedSvEstimator(self.n, self.H[:, self.sub], bias_index=self.H[:, self.sub].shape[1] - 1)
        self.x = np.zeros((self.n, 3))
        self.P = np.zeros((self.n, 3, 3))
        self.y = np.full((self.n, self.m), np.nan)
        self.S = np.full((self.n, self.m, self.m), np.nan)
        self._pending: tuple[ImuInterval, np.ndarray] | None = None
        self.initialised = False
        self.rejected = 0  # estimates refused by the positive-definiteness check
        self.skipped = 0  # updates skipped because an innovation covariance was not positive definite

    @property
    def skipped_stacked(self) -> int:
        return self.estimator.skipped

    @property
    def count(self) -> int:
        return self.estimator.count

    @property
    def matching(self) -> MatchingLeastSquares:
        return self.estimator.matching

    @property
    def S_ls(self) -> np.ndarray:
        return self.estimator.estimate

    def initialise(self, x0: np.ndarray, P0: np.ndarray) -> None:
        self.x = np.array(x0, dtype=float).reshape(self.n, 3)
        self.P = np.array(P0, dtype=float).reshape(self.n, 3, 3)
        self._pending = None
        self.estimator.reset_chain()
        self.initialised = True

    def predict(self, x_pred: np.ndarray, interval: ImuInterval) -> None:
        """Covariance over ``interval`` (eq. 23) to the propagated ``x_pred`` (n, 3); U = x_pred − F̂ x̂⁺ (eq. 17)."""
        Phi = interval.Phi
        U = np.asarray(x_pred, dtype=float) - self.x @ Phi.T
        self.P = self.predicted_P(interval)
        self.x = np.array(x_pred, dtype=float)
        self._pending = (interval, U)

    def predicted_P(self, interval: ImuInterval) -> np.ndarray:
        Phi = interval.Phi
        P = Phi @ self.P @ Phi.T + self.S_used[:, None, None] * interval.Qa1
        P[:, 2, 2] += interval.qb
        return P

    def nis(self, z: np.ndarray, R: np.ndarray) -> np.ndarray:
        """NIS per axis of the update with ``z`` (n, m), ``R`` (n, m, m), not applied (NaN if an S is not PD)."""
        z = np.asarray(z, dtype=float).reshape(self.n, self.m)
        S = self.H @ self.P @ self.H.T + np.asarray(R, dtype=float).reshape(self.n, self.m, self.m)
        if not _all_positive_definite(S):
            return np.full(self.n, np.nan)
        nu = z - self.x @ self.H.T
        return np.einsum("ni,ni->n", nu, np.linalg.solve(S, nu[:, :, None])[:, :, 0])

    def update(self, z: np.ndarray, R: np.ndarray, new_chain: bool = False) -> np.ndarray:
        """Joseph update (24)–(27) with ``z`` (n, m), ``R`` (n, m, m), a stacked step unless ``new_chain``; NIS (n,)."""
        z = np.asarray(z, dtype=float).reshape(self.n, self.m)
        R = np.asarray(R, dtype=float).reshape(self.n, self.m, self.m)
        H = self.H
        HP = H @ self.P  # (n, m, 3)
        S = HP @ H.T + R
        nu = z - self.x @ H.T
        self.y, self.S = nu, S
        if not _all_positive_definite(S):
            # beyond the paper: no update is possible (zero covariance, zero interval); skip it, restart the chain
            self.skipped += 1
            self._pending = None
            self.estimator.reset_chain()
            return np.full(self.n, np.nan)
        Sinv = 1.0 / S if self.m == 1 else np.linalg.inv(S)
        K = np.swapaxes(HP, 1, 2) @ Sinv  # (n, 3, m)
        self.x = self.x + np.einsum("nim,nm->ni", K, nu)
        IKH = np.eye(3) - K @ H
        self.P = IKH @ self.P @ np.swapaxes(IKH, 1, 2) + K @ R @ np.swapaxes(K, 1, 2)
        nis = np.einsum("ni,nij,nj->n", nu, Sinv, nu)
        if self._pending is None or new_chain:
            self.estimator.add_epoch(z, R, None, None)
        else:
            interval, U = self._pending
            if self.estimator.add_epoch(z, R, interval.matrices(self.sub), U[:, self.sub]):
                self._accept(self.estimator.estimate)
        self._pending = None
        return nis

    def _accept(self, s_new: np.ndarray) -> None:
        """Positive-definiteness check with fallback to the last positive-definite estimate (after eq. 35)."""
        if self.estimator.count < self.min_samples:
            return
        if self.pd_check == "se_floor":
            used, kept = self.estimator.matching.working(self.S_used.tolist(), self.s_v0.tolist())
            self.S_used = np.array(used)
            self.rejected += int(kept > 0)
            return
        ok = np.isfinite(s_new) & (s_new > 0)
        if self.pd_check == "joint":
            ok = np.repeat(ok.reshape(-1, self.pd_group).all(axis=1), self.pd_group)
        self.S_used = np.where(ok, s_new, self.S_used)
        self.rejected += int((~ok).any())


def _all_positive_definite(S: np.ndarray) -> bool:
    """True if every (m, m) matrix of the stack ``S`` is finite and positive definite (Cholesky succeeds)."""
    if not np.all(np.isfinite(S)):
        return False
    try:
        np.linalg.cholesky(S)
    except np.linalg.LinAlgError:
        return False
    return True


def paper_interval(T: float, tau: float, sigma_ss: float) -> ImuInterval:
    """Interval of paper 004 for one IMU sample per measurement (eqs. 7, 17, 23): ``Q_a = S_v T Ĝ Ĝᵀ``."""
    phi = np.exp(-T / tau)
    half = T / 2.0
    return ImuInterval(T, T**2 / 2.0, T, phi, T * (half * half), T * half, (1.0 - phi**2) * sigma_ss**2)
