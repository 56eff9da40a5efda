"""The basis the steady engine's filters run in (:mod:`.steady`): A = U T U⁻¹ with T real block-diagonal (the modal
basis, 1 × 1 and 2 × 2 blocks) where U is well conditioned, else real quasi-triangular (Schur, U orthogonal); why:
docs/em.md, "Why the Kalman engines …"."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import schur


def blocks(T: np.ndarray) -> list[slice]:
    """The 1 × 1 and 2 × 2 diagonal blocks of quasi-triangular T, in order."""
    p = T.shape[0]
    out, i = [], 0
    while i < p:
        size = 2 if i + 1 < p and T[i + 1, i] != 0 else 1
        out.append(slice(i, i + size))
        i += size
    return out


#: Largest condition number of the real modal basis used instead of the Schur basis.
MODAL_MAX_COND = 1e6


@dataclass(frozen=True)
class Basis:
    """A = U T U⁻¹ with T real quasi-triangular (Schur, U orthogonal) or block-diagonal (``modal``)."""

    t: np.ndarray
    u: np.ndarray
    u_inv: np.ndarray
    modal: bool


def _modal_basis(A: np.ndarray) -> Basis | None:
    """The real modal basis of A when its condition number is below :data:`MODAL_MAX_COND`, else None."""
    lam, vec = np.linalg.eig(A)
    if not (np.all(np.isfinite(lam)) and np.all(np.isfinite(vec))):
        return None
    p = A.shape[0]
    cols, t = [], np.zeros((p, p))
    i = 0
    while i < p:
        if lam[i].imag == 0.0:
            t[i, i] = lam[i].real
            cols.append(vec[:, i].real)
            i += 1
            continue
        if i + 1 >= p or lam[i + 1] != np.conj(lam[i]):
            return None
        a, b = lam[i].real, lam[i].imag
        t[i: i + 2, i: i + 2] = [[a, b], [-b, a]]
        cols += [vec[:, i].real, vec[:, i].imag]
        i += 2
    u = np.column_stack(cols)
    if np.linalg.cond(u) > MODAL_MAX_COND:
        return None
    return Basis(t, u, np.linalg.inv(u), True)


def decoupled_basis(A: np.ndarray) -> Basis:
    """The basis the filters run in: modal where well conditioned, else real Schur."""
    modal = _modal_basis(A)
    if modal is not None:
        return modal
    T, U = schur(A, output="real")
    return Basis(T, U, U.T, False)
