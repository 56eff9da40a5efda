"""The steady-state prediction covariance P̄ of a Kalman filter (discrete algebraic Riccati equation).

Used for Σ = P̄ (``StateSpace.sigma_mode == 'steady'``: the filter is time-invariant from the first sample) and by
the whitening filter of the residual diagnostics.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

#: Most negative eigenvalue of P̄, relative to its largest, still taken for rounding of a covariance.
PSD_TOLERANCE = 1e-8


def _covariance(P: np.ndarray) -> np.ndarray:
    """``P`` when it is a covariance to rounding (symmetric, eigenvalues ≥ −:data:`PSD_TOLERANCE` × the largest),
    else InputError: with variances many decades apart (e.g. a Gauss–Markov σ of 300 beside a white noise of 1e-5
    per sample, met by an optimiser's trial steps) the iteration can converge in double precision to a matrix with a
    large negative eigenvalue, whose "likelihood" is finite and meaningless."""
    w = np.linalg.eigvalsh(P)
    if not (np.all(np.isfinite(w)) and w[0] >= -PSD_TOLERANCE * max(abs(w[-1]), abs(w[0]))):
        raise InputError("the steady-state prediction covariance is not positive semi-definite in double precision "
                         f"(eigenvalues {w[0]:.3g} … {w[-1]:.3g}); the model's variances are too far apart")
    return P


def _newton_dare(phi: np.ndarray, q: np.ndarray, h: np.ndarray, r: float, guess: np.ndarray) -> np.ndarray | None:
    """P̄ by Newton's method on the DARE (Hewer 1971) from ``guess``; None unless it converges in a few steps.

    With the gain L = Φ P hᵀ / (h P hᵀ + r) of the current P, the next P solves the Lyapunov equation
    P = A P Aᵀ + Q + r L Lᵀ, A = Φ − L h (Kronecker form, p² unknowns). Quadratic convergence from a nearby
    stabilising guess (e.g. P̄ of a model one finite-difference step away).
    """
    p = phi.shape[0]
    if guess.shape != (p, p) or not np.all(np.isfinite(guess)):
        return None
    P = guess
    eye = np.eye(p * p)
    for _ in range(6):
        gain = phi @ P @ h / (float(h @ P @ h) + r)
        A = phi - np.outer(gain, h)
        if np.max(np.abs(np.linalg.eigvals(A))) > 1.0 + 1e-12:  # not stabilising: Newton may go astray
            return None
        C = q + r * np.outer(gain, gain)
        P_new = np.linalg.solve(eye - np.kron(A, A), C.ravel()).reshape(p, p)
        P_new = 0.5 * (P_new + P_new.T)
        if not np.all(np.isfinite(P_new)):
            return None
        # Quadratic convergence: a step of relative size ≤ 1e-10 leaves an error ~1e-20, i.e. at the rounding
        # floor of the Kronecker solve (~1e-13 with poles near 1), where the doubling's 1e-14 test cannot be met.
        if np.max(np.abs(P_new - P)) <= 1e-10 * np.max(np.abs(P_new)):
            return P_new
        P = P_new
    return None


def steady_prediction_covariance(
    phi: np.ndarray, q: np.ndarray, h: np.ndarray, r: float, *, guess: np.ndarray | None = None
) -> np.ndarray:
    """Steady-state prediction covariance P̄ of the Kalman filter (discrete algebraic Riccati equation).

    P = Φ P (I + G P)⁻¹ Φᵀ + Q with G = Hᵀ R⁻¹ H, solved by the structure-preserving doubling algorithm
    (quadratic convergence: ~log2 of the slowest filter time constant iterations, each a few p×p products;
    far cheaper than a generalised-eigenvalue DARE solver for the tiny p here). With ``guess`` (P̄ of a nearby
    model), Newton's method from it is tried first (:func:`_newton_dare`; same stopping rule), doubling if it
    does not converge within a few steps (it agrees with the doubling to ~1e-13 relative).

    Raises
    ------
    InputError
        If R ≤ 0 (no white noise), the iteration does not converge (a non-detectable model) or what it converges to
        is not a covariance (:func:`_covariance`).
    """
    p = phi.shape[0]
    if p == 0:
        return np.zeros((0, 0))
    if not r > 0:
        raise InputError("the model has no steady-state Kalman filter: the white-noise variance R must be > 0")
    if guess is not None:
        P = _newton_dare(phi, q, h, float(r), np.asarray(guess, dtype=float))
        if P is not None:
            return _covariance(P)
    eye = np.eye(p)
    A = phi.T.copy()
    G = np.outer(h, h) / r
    X = q.copy()
    for _ in range(500):
        W = np.linalg.solve(eye + G @ X, A)  # (I + G X)⁻¹ A
        X_new = X + A.T @ X @ W
        G = G + A @ np.linalg.solve(eye + G @ X, G) @ A.T
        A = A @ W
        X_new = 0.5 * (X_new + X_new.T)
        if not np.all(np.isfinite(X_new)):
            break
        if np.max(np.abs(X_new - X)) <= 1e-14 * np.max(np.abs(X_new)):
            return _covariance(X_new)
        X = X_new
    raise InputError("the steady-state Riccati iteration did not converge; the model parameters are degenerate")
