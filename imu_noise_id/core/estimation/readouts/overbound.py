"""The smallest white noise + random walk (Kalibr's N and K) whose Allan variance covers a bound (beyond the papers).

Over τ_i with bounds b_i, find a = N² ≥ 0, c = K² ≥ 0 with

    AV_WN+RW(τ_i) = a·g(τ_i) + c·h(τ_i) ≥ b_i    for every i,   g = 1/τ,  h = τ/3 + dt²/(6τ)

(the sampled WN and RW AVs) minimising the mean ratio Σ_i AV_WN+RW(τ_i)/b_i: a two-variable linear programme solved
exactly at a vertex; optional floors N ≥ N₀, K ≥ K₀. Why: docs/analysis.md, "Overbound (the honest ×10)"."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...errors import InputError

#: Default end of the τ range [s] (which starts at dt): a VIO / GNSS-INS filter's scales up to its bias drift.
DEFAULT_HORIZON_S = 100.0
#: A vertex is feasible when every constraint holds to this relative tolerance (rounding of the 2×2 solve).
FEASIBLE_RTOL = 1e-9
#: A constraint is binding when the overbound's AV is within this relative distance of the bound.
BINDING_RTOL = 1e-6


@dataclass(frozen=True)
class WnRwOverbound:
    """The overbound of one axis: ``noise_density`` N [u/√Hz], ``random_walk`` K [u/s/√Hz] (0 when white noise covers
    the bound), ``binding_tau`` [s] where its AV touches the bound, ``at_floor`` (N, K at their floors) and
    ``mean_ratio`` (mean AV / bound, ≥ 1)."""

    noise_density: float
    random_walk: float
    binding_tau: tuple[float, ...]
    at_floor: tuple[bool, bool]
    mean_ratio: float

    def allan_variance(self, tau: np.ndarray, dt: float) -> np.ndarray:
        """The overbound's Allan variance [u²] at ``tau`` [s]."""
        return _basis(np.asarray(tau, dtype=float), dt) @ np.array([self.noise_density**2, self.random_walk**2])


def _basis(tau: np.ndarray, dt: float) -> np.ndarray:
    """(T, 2): the Allan variances of unit WN and unit RW at ``tau``."""
    from ...noise.components import RW, WN  # scipy.signal behind it: not imported with the CLI's defaults

    return np.column_stack([WN(1.0).allan_variance(tau, dt), RW(1.0).allan_variance(tau, dt)])


def _vertices(G: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Candidate vertices (a, c) of {x ≥ 0 : G x ≥ b}: the two axis points and every pairwise intersection."""
    on_axes = [[np.max(b / np.where(G[:, 0] > 0, G[:, 0], np.nan), initial=0.0, where=G[:, 0] > 0), 0.0],
               [0.0, np.max(b / np.where(G[:, 1] > 0, G[:, 1], np.nan), initial=0.0, where=G[:, 1] > 0)]]
    i, j = np.triu_indices(len(b), k=1)
    det = G[i, 0] * G[j, 1] - G[i, 1] * G[j, 0]
    ok = np.abs(det) > 0
    i, j, det = i[ok], j[ok], det[ok]
    a = (b[i] * G[j, 1] - b[j] * G[i, 1]) / det
    c = (G[i, 0] * b[j] - G[j, 0] * b[i]) / det
    return np.vstack([np.array(on_axes), np.column_stack([a, c])])


def overbound_wn_rw(tau: np.ndarray, bound: np.ndarray, dt: float,
                    floor: tuple[float, float] = (0.0, 0.0)) -> WnRwOverbound:
    """The WN + RW of least mean ratio whose AV is ≥ ``bound`` at every ``tau``; InputError without τ or with a bound
    not positive and finite.

    Parameters
    ----------
    tau : averaging times [s]
    bound : AV [u²] to cover at each τ (positive, finite)
    dt : sampling period [s]
    floor : (N₀ [u/√Hz], K₀ [u/s/√Hz]) the result is not below
    """
    tau = np.asarray(tau, dtype=float)
    bound = np.asarray(bound, dtype=float)
    if tau.size == 0 or tau.shape != bound.shape:
        raise InputError("the overbound needs at least one averaging time with its bound (check the τ range)")
    if not (np.all(np.isfinite(bound)) and np.all(bound > 0) and np.all(tau > 0)):
        raise InputError("the overbound needs positive, finite Allan bounds at positive τ")
    floor2 = np.square(np.asarray(floor, dtype=float))
    if not (np.all(np.isfinite(floor2)) and np.all(floor2 >= 0)):
        raise InputError(f"the overbound's floor must be finite and >= 0, got {floor}")
    G = _basis(tau, dt)
    cost = (G / bound[:, None]).sum(axis=0)  # Σ (G x)_i / b_i = cost · x
    rows = np.vstack([G, np.eye(2)])  # the floors as two more constraints x_k ≥ floor_k²
    rhs = np.concatenate([bound, floor2])
    cand = _vertices(rows, rhs)
    cand = cand[(cand >= 0).all(axis=1)]
    feasible = (cand @ rows.T >= rhs * (1 - FEASIBLE_RTOL)).all(axis=1)
    cand = cand[feasible]
    x = cand[np.argmin(cand @ cost)]
    # Exactly feasible in floating point: scale up by what rounding left below (≤ FEASIBLE_RTOL).
    need = rhs > 0
    x = x * max(1.0, float(np.max(rhs[need] / (rows[need] @ x))))
    av = G @ x
    binding = tuple(float(t) for t in tau[av <= bound * (1 + BINDING_RTOL)])
    at_floor = tuple(bool(f > 0 and v <= f * (1 + BINDING_RTOL)) for v, f in zip(x, floor2, strict=True))
    return WnRwOverbound(noise_density=math.sqrt(x[0]), random_walk=math.sqrt(x[1]), binding_tau=binding,
                         at_floor=at_floor, mean_ratio=float(np.mean(av / bound)))
