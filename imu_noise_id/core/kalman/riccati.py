"""Steady-state prediction covariance P̄ (DARE) for Σ = P̄ and the whitening filter; why: docs/em.md."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_discrete_are

from ..errors import InputError

#: Machine epsilon of float64.
EPS = float(np.finfo(float).eps)
#: Most negative eigenvalue of P̄, relative to its largest, still taken for rounding of a covariance.
PSD_TOLERANCE = 1e-8


def _covariance(P: np.ndarray) -> np.ndarray:
    """``P`` if a covariance to rounding (eigenvalues ≥ −:data:`PSD_TOLERANCE` × the largest), else InputError."""
    w = np.linalg.eigvalsh(P)
    if not (np.all(np.isfinite(w)) and w[0] >= -PSD_TOLERANCE * max(abs(w[-1]), abs(w[0]))):
        raise InputError("the steady-state prediction covariance is not positive semi-definite in double precision "
                         f"(eigenvalues {w[0]:.3g} … {w[-1]:.3g}); the model's variances are too far apart")
    return P


#: A first Newton step that changes a state's variance by more than this share of the new value starts from a guess
#: too far for Newton's few steps: far from P̄ its steps only about halve the error (14–21 steps where a fit's starts and
#: profile points moved a walk's variance by decades), and the doubling costs about as much as six of them.
NEWTON_FAR = 0.5


def _newton_dare(phi: np.ndarray, q: np.ndarray, h: np.ndarray, r: float, guess: np.ndarray) -> np.ndarray | None:
    """P̄ by Newton's method from ``guess`` (Hewer 1971): P = A P Aᵀ + Q + r L Lᵀ, A = Φ − L h, L = Φ P hᵀ/(h P hᵀ +
    r), each step's Stein equation summed by doubling (:func:`_stein_sum`, O(p³) per doubling, not the p² × p²
    Kronecker solve); None unless it converges in a few steps, and at once after a first step of more than
    :data:`NEWTON_FAR`."""
    p = phi.shape[0]
    if guess.shape != (p, p) or not np.all(np.isfinite(guess)):
        return None
    P = guess
    for step in range(6):
        gain = phi @ P @ h / (float(h @ P @ h) + r)
        A = phi - np.outer(gain, h)
        rho = float(np.max(np.abs(np.linalg.eigvals(A))))
        if rho > 1.0 + 1e-12:  # not stabilising: Newton may go astray
            return None
        C = q + r * np.outer(gain, gain)
        with np.errstate(over="ignore", invalid="ignore"):  # a pole on the unit circle: no finite sum, None below
            P_new = _stein_sum(A.T, C, rho=rho)  # Σ_j Aʲ C Aʲᵀ: P = A P Aᵀ + C
        if not np.all(np.isfinite(P_new)):
            return None
        # quadratic convergence: a 1e-10 step leaves ~1e-20, below the Stein sum's rounding floor; and each state's
        # variance to 1e-6 of itself (a walk driven far below the others is not converged by their scale), or to
        # its rounding, which grows as ε/(1 − ρ) as the closed loop's pole nears 1 (1e-5 at 1 − 10⁻¹¹)
        change = P_new - P
        if converged(change, P_new, 1e-10, max(1e-6, 1e3 * EPS / max(1.0 - rho, EPS))):
            return P_new
        if step == 0 and np.any(np.abs(np.diagonal(change)) > NEWTON_FAR * np.abs(np.diagonal(P_new))):
            return None
        P = P_new
    return None


def steady_prediction_covariance(
    phi: np.ndarray, q: np.ndarray, h: np.ndarray, r: float, *, guess: np.ndarray | None = None
) -> np.ndarray:
    """P̄: P = Φ P (I + G P)⁻¹ Φᵀ + Q, G = Hᵀ R⁻¹ H (Newton from ``guess``, doubling, and the generalised Schur method
    where the doubling fails or ends off a covariance to rounding); InputError if R ≤ 0, undetectable, or no
    covariance."""
    p = phi.shape[0]
    if p == 0:
        return np.zeros((0, 0))
    if not r > 0:
        raise InputError("the model has no steady-state Kalman filter: the white-noise variance R must be > 0")
    if guess is not None:
        P = _newton_dare(phi, q, h, float(r), np.asarray(guess, dtype=float))
        if P is not None:
            return _covariance(P)
    try:
        return _covariance(_doubling_dare(phi, q, h, float(r)))
    except (np.linalg.LinAlgError, InputError):  # I + G X singular, no convergence, or a P̄ off a covariance
        return _covariance(_schur_dare(phi, q, h, float(r)))


def _doubling_dare(phi: np.ndarray, q: np.ndarray, h: np.ndarray, r: float) -> np.ndarray:
    """P̄ by structure-preserving doubling; LinAlgError when I + G X is singular in double precision."""
    p = phi.shape[0]
    eye = np.eye(p)
    A = phi.T.copy()
    G = np.outer(h, h) / r
    X = q.copy()
    for _ in range(500):
        with np.errstate(over="ignore", invalid="ignore"):  # a diverging iteration: not finite, stopped below
            both = np.linalg.solve(eye + G @ X, np.hstack([A, G]))  # (I + G X)⁻¹ [A, G], one factorisation
            W = both[:, :p]
            X_new = X + A.T @ X @ W
            G = G + A @ both[:, p:] @ A.T
            A = A @ W
            X_new = 0.5 * (X_new + X_new.T)
        if not np.isfinite(X_new).all():
            break
        if converged(X_new - X, X_new, 1e-14, 1e-12):
            return X_new
        X = X_new
    raise InputError("the steady-state Riccati iteration did not converge; the model parameters are degenerate")


def _schur_dare(phi: np.ndarray, q: np.ndarray, h: np.ndarray, r: float) -> np.ndarray:
    """P̄ by the generalised Schur method (scipy's ``solve_discrete_are``, Arnold & Laub 1984); InputError where it
    has no finite solution in double precision (a trial point far out: scipy's balancing then meets values it cannot
    cast, quietly here)."""
    try:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # not finite: refused below
            P = solve_discrete_are(phi.T, h.reshape(-1, 1), q, np.array([[r]]))
    except (np.linalg.LinAlgError, ValueError) as err:
        raise InputError(f"the steady-state Riccati equation has no solution in double precision ({err}); the "
                         "model parameters are degenerate") from err
    if not np.isfinite(P).all():
        raise InputError("the steady-state Riccati equation has no finite solution in double precision; the model "
                         "parameters are degenerate")
    return 0.5 * (P + P.T)


#: Doublings of the Stein sum at most: 2⁶⁴ terms, beyond any closed-loop pole of a model the filter can run.
STEIN_DOUBLINGS = 64


def converged(change: np.ndarray, M: np.ndarray, overall: float, own: float) -> bool:
    """Whether ``change`` is below ``overall`` of M's largest entry and each diagonal entry's change below ``own`` of
    that entry: the second judges a state far smaller than the others (a walk the fit drove to ~0 beside a GM) at its
    own scale, not the largest's. For a covariance's change the diagonal bounds the rest (|c_ij| ≤ √(c_ii c_jj))."""
    size = np.abs(change)  # (the arrays' own methods: p × p arrays, where np.max's dispatch cost the most)
    return bool(size.max() <= overall * np.abs(M).max()
                and (np.diagonal(size) <= own * np.abs(np.diagonal(M))).all())


#: The Stein sum's increments are judged once ρ(A)^(2^(k+1)) ≤ this: its 1e-16 to the power ¼, room for a
#: non-normal A's transient; before, an increment from a slow mode cannot be converged yet.
STEIN_JUDGED_FROM = 1e-4


def _stein_sum(A: np.ndarray, W: np.ndarray, *, rho: float | None = None) -> np.ndarray:
    """M = Σ_{j≥0} Aʲᵀ W Aʲ (M = Aᵀ M A + W, A stable) by doubling until an increment is :func:`converged` to 1e-16,
    of the largest entry and of each diagonal entry's own; no linear solve. Judged on the largest entry alone, the
    sum of a walk driven to ~0 beside a GM stopped short of the walk's own scale (``test_kalman.py``). With ρ(A)
    given (``rho``), the increments are judged from the doubling where ρ^(2^(k+1)) ≤ :data:`STEIN_JUDGED_FROM` (a
    pole 10⁻⁴ from 1 takes 20 doublings; judging the first 16 costs more than the products)."""
    M = 0.5 * (W + W.T)
    Ak = A
    judged_from = 0
    if rho is not None and 0.0 < rho < 1.0:
        judged_from = max(0, math.floor(math.log2(math.log(STEIN_JUDGED_FROM) / math.log(rho))) - 1)
    for k in range(STEIN_DOUBLINGS):
        increment = Ak.T @ M @ Ak
        M = M + 0.5 * (increment + increment.T)
        if k >= judged_from and converged(increment, M, 1e-16, 1e-16):
            break
        Ak = Ak @ Ak
    return M


#: Least distance of the closed loop's poles from the unit circle at which :class:`SteadyCovarianceSensitivity` is
#: computed (its adjoint sum has ~1/gap terms).
UNIT_POLE_GAP = 1e-12


@dataclass(frozen=True)
class SteadyCovarianceSensitivity:
    """First-order change of tr(W P̄): ⟨G_Φ, dΦ⟩ + ⟨G_Q, dQ⟩ + g_h·dh + g_r·dr, with the adjoint M = Aᵀ M A + W (Giles
    2008; Anderson & Moore 1979 §4.4; derivation: docs/em.md), A = Φ(I − K h), P_u = P̄ − S K Kᵀ, N = Φᵀ M Φ::

        G_Φ = 2 M Φ P_u,   G_Q = M,   g_r = Kᵀ N K,   g_h = −2 P̄ (I − K h)ᵀ N K.

    For the initial-state term of the gradient (:class:`~..estimation.em.em.MatrixScore`).
    """

    g_phi: np.ndarray
    g_q: np.ndarray
    g_h: np.ndarray
    g_r: float

    @classmethod
    def of(cls, phi: np.ndarray, q: np.ndarray, h: np.ndarray, r: float, *, P: np.ndarray,
           W: np.ndarray) -> SteadyCovarianceSensitivity | None:
        """The sensitivity at P̄ = ``P`` (the DARE's solution for Φ, Q, h, r; W symmetric); None where the closed
        loop A has a pole within :data:`UNIT_POLE_GAP` of the unit circle (the adjoint sum then has more than 10¹²
        terms, and a walk driven to ~0 beside a GM as slow as a walk gave entries of 10¹⁶⁰) or an entry is not
        finite (a W from a P̄ with entries near zero overflows the sum)."""
        s = float(h @ P @ h) + r
        K = P @ h / s
        P_u = P - s * np.outer(K, K)
        A = phi - np.outer(phi @ K, h)
        rho = float(np.abs(np.linalg.eigvals(A)).max()) if A.size else 0.0
        if not rho < 1.0 - UNIT_POLE_GAP:
            return None
        with np.errstate(over="ignore", invalid="ignore"):  # not finite: None below
            M = _stein_sum(A, W, rho=rho)
            N = phi.T @ M @ phi
            NK = N @ K
            closed = np.eye(h.size) - np.outer(K, h)
            out = cls(g_phi=2.0 * M @ phi @ P_u, g_q=M, g_h=-2.0 * P @ closed.T @ NK, g_r=float(K @ NK))
        finite = all(np.all(np.isfinite(v)) for v in (out.g_phi, out.g_q, out.g_h, out.g_r))
        return out if finite else None
