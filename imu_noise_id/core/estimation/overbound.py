"""The smallest white noise + random walk (Kalibr's two numbers) whose Allan variance lies above a given bound.

Beyond the papers: the honest answer to "why must I inflate my noise ×10 before my filter works?". A filter that
models an axis as WN + RW (Kalibr's N and K) is consistent at a time scale τ only if the model's Allan variance
is at least what the sensor really does at τ. Where the sensor has more than WN + RW (bias instability, a
Gauss–Markov bump, vibration lines, a low-pass) the fitted N and K under-state it, and the user inflates by hand.
Here the inflation is computed: over the averaging times τ_i the user's filter cares about, with b_i the bound to
cover (the data's upper 95 % Allan bound and the final model's AV), find a = N² ≥ 0 and c = K² ≥ 0 with

    AV_WN+RW(τ_i) = a·g(τ_i) + c·h(τ_i) ≥ b_i    for every i,

g = 1/τ and h = τ/3 + dt²/(6τ) the exact Allan variances of unit WN and RW sampled at dt
(:meth:`~imu_noise_id.core.noise.components.WN.allan_variance`, :meth:`~imu_noise_id.core.noise.components.RW.
allan_variance`). Constraints and unknowns are linear in (a, c): a two-variable linear programme.

Objective (which "smallest", and why): minimise Σ_i AV_WN+RW(τ_i) / b_i — the mean ratio of the overbound's AV
to the bound over the τ grid. It is linear (so the optimum is a vertex of the feasible polygon and is found
exactly by enumerating the vertices), scale-free (each τ counts by how far the overbound sits above *its* bound,
not by the size of the AV there), and on the log-spaced Allan grid every decade of time scales weighs the same.
At the optimum the AV touches the bound at one or two τ (the binding ones): lowering N or K breaks the bound there.

Optionally the two numbers are kept at or above floors (N ≥ N₀, K ≥ K₀: the fitted values), two more linear
constraints: the inflation factors over the fitted values are then ≥ 1, and a random walk is not dropped because
the τ range is too short to see it. A floor that binds is reported like a binding τ.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

#: Default end of the τ range [s] (it starts at the sampling period): the time scales of a VIO / GNSS-INS filter
#: between aiding updates and the bias drift it must follow, from a fraction of a second to minutes.
DEFAULT_HORIZON_S = 100.0
#: A vertex is feasible when every constraint holds to this relative tolerance (rounding of the 2×2 solve).
FEASIBLE_RTOL = 1e-9
#: A constraint is binding when the overbound's AV is within this relative distance of the bound.
BINDING_RTOL = 1e-6


@dataclass(frozen=True)
class WnRwOverbound:
    """The overbound of one axis.

    Attributes
    ----------
    noise_density : N [u/√Hz]
    random_walk : K [u/s/√Hz] (0 when white noise alone covers the bound)
    binding_tau : the τ [s] where the overbound's AV touches the bound
    at_floor : (N at its floor, K at its floor)
    mean_ratio : the objective: mean over the τ grid of AV_overbound / bound (≥ 1)
    """

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
    from ..noise.components import RW, WN  # scipy.signal behind it: not imported with the CLI's defaults

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
    """The WN + RW of least mean ratio whose Allan variance is ≥ ``bound`` at every ``tau`` (module docstring).

    Parameters
    ----------
    tau : averaging times [s] (the τ range the filter cares about, e.g. the Allan grid within it)
    bound : the Allan variance [u²] to cover at each τ (positive, finite)
    dt : sampling period [s] (the exact discrete RW Allan variance depends on it)
    floor : (N₀ [u/√Hz], K₀ [u/s/√Hz]): the result is not below them (default: no floor)

    Raises
    ------
    InputError
        No τ, or a bound that is not positive and finite.
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
