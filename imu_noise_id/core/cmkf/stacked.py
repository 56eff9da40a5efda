"""Stacked-measurement covariance estimator of paper 004 (Moghe, Zanetti, Akella), eqs. (28)–(35), per axis of
state ``[r, v, b]``: 𝒵_k (33), Cov(𝒵) = Cov(𝒲) + S_v D + Cov(ℰ) (34), Ŝ_v = Σ ⟨𝒵𝒵ᵀ − Cov(𝒲) − Cov(ℰ), D⟩_F /
Σ ⟨D, D⟩_F (35) with the interval's own matrices (A₁, A₂, E₁–E₃ re-derived: docs/cmkf.md, "A₁, A₂ of eq. (35)")."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from .matching import MatchingLeastSquares


@dataclass(frozen=True)
class Interval:
    """One interval shared by all axes: ``Phi`` F̂ (d, d) (eq. 17), ``Qa1`` Cov ν for S_v = 1, ``qb`` (eq. 7) [m²/s⁴]."""

    Phi: np.ndarray
    Qa1: np.ndarray
    qb: float


@dataclass(frozen=True)
class _Epoch:
    z: np.ndarray  # (n, m)
    R: np.ndarray  # (n, m, m)
    interval: Interval | None  # interval leading to this epoch
    U: np.ndarray | None  # (n, d) known-input contribution over that interval
    Mo_pinv: np.ndarray | None  # M_o† = [H F̂; H]† of that interval (eq. 29)


class StackedSvEstimator:
    """Recursive least-squares S_v (eqs. 28–35) of ``n_axes`` sharing the interval matrices, ``H`` (m, d) of one axis
    on the (sub-)state, the bias at ``bias_index`` (``Λ = e_bias``); :meth:`add_epoch` at every epoch."""

    def __init__(self, n_axes: int, H: np.ndarray, bias_index: int) -> None:
        self.n_axes = int(n_axes)
        self.H = np.atleast_2d(np.asarray(H, dtype=float))
        self.m, self.d = self.H.shape
        self.Lam = np.zeros(self.d)
        self.Lam[bias_index] = 1.0
        self._HLam = self.H @ self.Lam
        self._eye = np.eye(self.d)
        self.matching = MatchingLeastSquares(self.n_axes)
        self.skipped = 0  # epochs whose M_o could not be inverted (zero-length interval): the chain restarts
        self._chain: deque[_Epoch] = deque(maxlen=3)
        self.last_Z: np.ndarray | None = None

    def reset_chain(self) -> None:
        """Forget the last epochs (after a gap); the accumulated statistics are kept."""
        self._chain.clear()

    @property
    def count(self) -> int:
        return self.matching.count

    @property
    def estimate(self) -> np.ndarray:
        """Least-squares Ŝ_v per axis [m²/s³] (NaN before the first stacked sample)."""
        return self.matching.estimate

    def add_epoch(self, z: np.ndarray, R: np.ndarray, interval: Interval | None, U: np.ndarray | None) -> bool:
        """Add epoch k: ``z`` (n, m), ``R`` (n, m, m), ``interval`` k-1 → k (None: new chain), ``U`` (n, d) = x̂⁻_k − F̂
        x̂⁺_{k-1}; True when a stacked sample 𝒵_k was accumulated."""
        Mo_pinv = None if interval is None else _pinv_full_rank(np.vstack([self.H @ interval.Phi, self.H]))
        if interval is not None and Mo_pinv is None:
            self.skipped += 1
            interval = U = None  # beyond the paper: a degenerate interval starts a new chain instead of raising
        if interval is None:
            self._chain.clear()
        self._chain.append(_Epoch(np.asarray(z, float), np.asarray(R, float), interval, U, Mo_pinv))
        if len(self._chain) < 3:
            return False
        e2, e1, e0 = self._chain  # epochs k-2, k-1, k
        if e0.interval is None or e1.interval is None:
            return False
        m = self.m
        Mk = e0.Mo_pinv  # M_{o,k}†  (d, 2m)
        Mk1 = e1.Mo_pinv  # M_{o,k-1}†
        Phi1 = e1.interval.Phi
        HU0 = e0.U @ self.H.T  # (n, m)
        HU1 = e1.U @ self.H.T
        Yk = np.concatenate([e0.z - HU0, e1.z], axis=1)  # (n, 2m)
        Yk1 = np.concatenate([e1.z - HU1, e2.z], axis=1)
        Z = Yk @ Mk.T - (Yk1 @ Mk1.T) @ Phi1.T - e1.U  # (n, d)   eq. (33)
        E1 = Mk[:, :m]  # M_o† [I; 0]
        F1 = Phi1 @ Mk1[:, :m]  # F̂ M_o† [I; 0]
        A1 = -E1 @ self.H  # −M_o† M_v   (M_v = [H; 0])
        A2 = F1 @ self.H - self._eye  # F̂ M_o† M_v − I
        D = A1 @ e0.interval.Qa1 @ A1.T + A2 @ e1.interval.Qa1 @ A2.T  # eq. (35) basis
        B1 = E1 @ self._HLam  # M_o† M_w  (M_w = [HΛ; 0])
        B2 = self.Lam - F1 @ self._HLam
        E2 = Mk[:, m:] - F1
        E3 = -Phi1 @ Mk1[:, m:]
        # ⟨Z Zᵀ − Cov(𝒲) − Cov(ℰ), D⟩_F per axis, with ⟨E R Eᵀ, D⟩ = ⟨R, Eᵀ D E⟩ (no per-axis d×d products)
        cw = e0.interval.qb * (B1 @ D @ B1) + e1.interval.qb * (B2 @ D @ B2)
        ce = (
            np.sum(e0.R * (E1.T @ D @ E1), axis=(1, 2))
            + np.sum(e1.R * (E2.T @ D @ E2), axis=(1, 2))
            + np.sum(e2.R * (E3.T @ D @ E3), axis=(1, 2))
        )
        self.matching.add((np.sum((Z @ D) * Z, axis=1) - cw - ce).tolist(), float(np.sum(D * D)))
        self.last_Z = Z
        return True


def _pinv_full_rank(M: np.ndarray, rcond: float = 1e-12) -> np.ndarray | None:
    """(MᵀM)⁻¹Mᵀ of a full-column-rank M (eq. 29); None when rank deficient (condition > 1/rcond) or not finite."""
    if not np.all(np.isfinite(M)):
        return None
    sv = np.linalg.svd(M, compute_uv=False)
    if sv[-1] <= rcond * sv[0]:
        return None
    return np.linalg.solve(M.T @ M, M.T)


def cov_z_model(
    Phi: np.ndarray, H: np.ndarray, *, Qa1: np.ndarray, qb: float, R: np.ndarray, S_v: float, bias_index: int
) -> np.ndarray:
    """Cov(𝒵) of eq. (34) for constant matrices (one axis): Cov(𝒲) + S_v D + Cov(ℰ)."""
    H = np.atleast_2d(H)
    m, d = H.shape
    Lam = np.zeros(d)
    Lam[bias_index] = 1.0
    Mp = np.linalg.pinv(np.vstack([H @ Phi, H]))
    Mv = np.vstack([H, np.zeros_like(H)])
    A1 = -Mp @ Mv
    A2 = Phi @ Mp @ Mv - np.eye(d)
    Mw = np.concatenate([H @ Lam, np.zeros(m)])
    B1 = Mp @ Mw
    B2 = Lam - Phi @ Mp @ Mw
    E1 = Mp[:, :m]
    E2 = Mp[:, m:] - Phi @ Mp[:, :m]
    E3 = -Phi @ Mp[:, m:]
    cov_w = qb * (np.outer(B1, B1) + np.outer(B2, B2))
    cov_v = S_v * (A1 @ Qa1 @ A1.T + A2 @ Qa1 @ A2.T)
    cov_e = E1 @ R @ E1.T + E2 @ R @ E2.T + E3 @ R @ E3.T
    return cov_w + cov_v + cov_e
