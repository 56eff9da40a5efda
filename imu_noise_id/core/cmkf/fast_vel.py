"""Paper 004's CMKF for velocity-only measurements in plain floats (the robot's hot path): :class:`~.axis.AxisCmkf`
in mode ``"vel"`` written out (tested equal) on the observable [v, b] (r carried): H = [1, 0], F̂ = [[1, −β_v], [0, φ]],
propagation (23), Joseph update (27), stacked estimator (28)–(35) with M_o⁻¹ = [[0, 1], [−1/β_v, 1/β_v]]."""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from .interval import ImuInterval
from .matching import MatchingLeastSquares


class _Epoch:
    __slots__ = ("Bv", "R", "T", "U", "beta", "inv", "qb", "z")

    def __init__(self, z: list[float], R: list[float], interval: ImuInterval | None,
                 U: list[tuple[float, float]] | None) -> None:
        self.z, self.R, self.U = z, R, U
        if interval is None:
            self.T = self.Bv = self.beta = self.qb = math.nan
            self.inv = None
        else:
            self.T, self.Bv, self.beta, self.qb = interval.T, interval.Bv, interval.phi, interval.qb
            # M_o⁻¹ row-major; M_o is singular for a zero-length interval (β_v = 0): no stacked step uses it
            self.inv = (0.0, 1.0, -1.0 / self.Bv, 1.0 / self.Bv) if self.Bv > 0.0 else None

    @property
    def degenerate(self) -> bool:
        """True when the epoch has an interval but M_o of that interval cannot be inverted."""
        return self.inv is None and not math.isnan(self.T)


class VelocityAxisCmkf:
    """Velocity-measurement CMKF (a :class:`~.protocol.CmkfFilter` with m = 1) of ``n_axes``, initial Ŝ_v ``s_v0``
    [m²/s³] (ValueError unless > 0), ``pd_check``, ``min_samples`` before it uses Ŝ_v."""

    m = 1

    def __init__(self, n_axes: int, s_v0: float, *, pd_check: str = "per_axis", min_samples: int = 1) -> None:
        if not (math.isfinite(s_v0) and s_v0 > 0):
            raise ValueError(f"initial S_v must be finite and > 0, got {s_v0}")
        self.n = int(n_axes)
        self.pd_check = pd_check
        self.min_samples = int(min_samples)
        self._S = [float(s_v0)] * self.n
        self._prior = [float(s_v0)] * self.n
        self._r = [0.0] * self.n
        self._v = [0.0] * self.n
        self._b = [0.0] * self.n
        self._pvv = [0.0] * self.n
        self._pvb = [0.0] * self.n
        self._pbb = [0.0] * self.n
        self._nu = [math.nan] * self.n
        self._s = [math.nan] * self.n
        self.matching = MatchingLeastSquares(self.n)
        self.rejected = 0
        self.skipped = 0  # updates skipped: innovation variance not positive
        self.skipped_stacked = 0  # stacked steps skipped: zero-length interval (M_o singular)
        self.initialised = False
        self._chain: deque[_Epoch] = deque(maxlen=3)
        self._pending: tuple[ImuInterval, list[tuple[float, float]]] | None = None

    # -- state ---------------------------------------------------------------------------------------------------
    def initialise(self, x0: np.ndarray, P0: np.ndarray) -> None:
        """Set x̂₀ (n, 3) and the ``[v, b]`` block of P₀ (n, 3, 3) (``r`` carried, not estimated); a new chain."""
        x0 = np.asarray(x0, dtype=float).reshape(self.n, 3)
        P0 = np.asarray(P0, dtype=float).reshape(self.n, 3, 3)
        self._r, self._v, self._b = (col.tolist() for col in x0.T)
        self._pvv, self._pvb, self._pbb = P0[:, 1, 1].tolist(), P0[:, 1, 2].tolist(), P0[:, 2, 2].tolist()
        self._chain.clear()
        self._pending = None
        self.initialised = True

    @property
    def x(self) -> np.ndarray:
        return np.array([self._r, self._v, self._b]).T

    @property
    def P(self) -> np.ndarray:
        return self._covariance(self._pvv, self._pvb, self._pbb)

    @property
    def y(self) -> np.ndarray:
        return np.array(self._nu)[:, None]

    @property
    def S(self) -> np.ndarray:
        return np.array(self._s)[:, None, None]

    @property
    def S_used(self) -> np.ndarray:
        return np.array(self._S)

    @property
    def count(self) -> int:
        return self.matching.count

    @property
    def S_ls(self) -> np.ndarray:
        return self.matching.estimate

    def _covariance(self, pvv: list[float], pvb: list[float], pbb: list[float]) -> np.ndarray:
        out = np.full((self.n, 3, 3), np.nan)
        out[:, 1, 1], out[:, 1, 2], out[:, 2, 1], out[:, 2, 2] = pvv, pvb, pvb, pbb
        return out

    def _propagated(self, interval: ImuInterval) -> tuple[list[float], list[float], list[float]]:
        """(P_vv, P_vb, P_bb) per axis after ``interval`` (eq. 23)."""
        T, Bv, beta, qb = interval.T, interval.Bv, interval.phi, interval.qb
        pvv, pvb, pbb, S = self._pvv, self._pvb, self._pbb, self._S
        return ([pvv[i] - 2 * Bv * pvb[i] + Bv * Bv * pbb[i] + S[i] * T for i in range(self.n)],
                [beta * (pvb[i] - Bv * pbb[i]) for i in range(self.n)],
                [beta * beta * pbb[i] + qb for i in range(self.n)])

    def predicted_P(self, interval: ImuInterval) -> np.ndarray:
        return self._covariance(*self._propagated(interval))

    # -- filter --------------------------------------------------------------------------------------------------
    def predict(self, x_pred: np.ndarray, interval: ImuInterval) -> None:
        """Covariance over ``interval`` (β_v = Σβ_j dt_j, φ = Πφ_j, q_b) to the propagated ``x_pred`` (n, 3)."""
        Bv, beta = interval.Bv, interval.phi
        U = []
        for i in range(self.n):
            r, v, b = x_pred[i]
            U.append((v - (self._v[i] - Bv * self._b[i]), b - beta * self._b[i]))
            self._r[i], self._v[i], self._b[i] = float(r), float(v), float(b)
        self._pvv, self._pvb, self._pbb = self._propagated(interval)
        self._pending = (interval, U)

    def nis(self, z: np.ndarray, R: np.ndarray) -> np.ndarray:
        """NIS per axis of the update with ``z`` (n, 1), ``R`` (n, 1, 1), without updating (NaN where s ≤ 0)."""
        out = []
        for i in range(self.n):
            nu, s = float(z[i][0]) - self._v[i], self._pvv[i] + float(R[i][0][0])
            out.append(nu * nu / s if s > 0.0 else math.nan)
        return np.array(out)

    def update(self, z: np.ndarray, R: np.ndarray, new_chain: bool = False) -> np.ndarray:
        """Joseph update (24)–(27) and one estimator step; NIS per axis. Where s = P_vv + R ≤ 0: skipped (``skipped``),
        NaN, chain restarted."""
        n = self.n
        z = [float(z[i][0]) for i in range(n)]
        R = [float(R[i][0][0]) for i in range(n)]
        self._nu = [z[i] - self._v[i] for i in range(n)]
        self._s = [self._pvv[i] + R[i] for i in range(n)]
        if not all(s > 0.0 for s in self._s):
            self.skipped += 1
            self._chain.clear()
            self._pending = None
            return np.full(n, np.nan)
        nis = []
        for i in range(n):
            pvv, pvb, pbb, r = self._pvv[i], self._pvb[i], self._pbb[i], R[i]
            s, nu = self._s[i], self._nu[i]
            kv, kb = pvv / s, pvb / s
            self._v[i] += kv * nu
            self._b[i] += kb * nu
            a = 1.0 - kv
            self._pvv[i] = a * a * pvv + kv * kv * r
            self._pvb[i] = a * (pvb - kb * pvv) + kv * kb * r
            self._pbb[i] = kb * kb * pvv - 2 * kb * pvb + pbb + kb * kb * r
            nis.append(nu * nu / s)
        if self._pending is None or new_chain:
            self._chain.clear()
            self._chain.append(_Epoch(z, R, None, None))
        else:
            interval, U = self._pending
            epoch = _Epoch(z, R, interval, U)
            self._chain.append(epoch)
            self.skipped_stacked += epoch.degenerate
            if self._stack():
                self._accept()
        self._pending = None
        return np.array(nis)

    def _stack(self) -> bool:
        """Eqs. (28)–(35) for the last three epochs: D = T_k a₁a₁ᵀ + T_{k−1} a₂a₂ᵀ, Cov(𝒲) = q_b e_b e_bᵀ."""
        if len(self._chain) < 3:
            return False
        e2, e1, e0 = self._chain
        if e0.inv is None or e1.inv is None:
            return False
        k00, k01, k10, k11 = e0.inv  # M_o,k⁻¹
        j00, j01, j10, j11 = e1.inv  # M_o,k−1⁻¹
        Bv1, beta1 = e1.Bv, e1.beta
        # E1 = M_o,k⁻¹[:, 0]; F1 = F̂_{k-1} M_o,k−1⁻¹[:, 0]; E2 = M_o,k⁻¹[:, 1] − F1; E3 = −F̂_{k-1} M_o,k−1⁻¹[:, 1]
        e1v, e1b = k00, k10
        f1v, f1b = j00 - Bv1 * j10, beta1 * j10
        e2v, e2b = k01 - f1v, k11 - f1b
        e3v, e3b = -(j01 - Bv1 * j11), -beta1 * j11
        a1v, a1b = -e1v, -e1b  # first column of A₁ = −M_o† M_v
        a2v, a2b = f1v - 1.0, f1b  # first column of A₂ = F̂ M_o† M_v − I
        T0, T1 = e0.T, e1.T
        dvv = T0 * a1v * a1v + T1 * a2v * a2v
        dvb = T0 * a1v * a1b + T1 * a2v * a2b
        dbb = T0 * a1b * a1b + T1 * a2b * a2b
        g1 = e1v * e1v * dvv + 2 * e1v * e1b * dvb + e1b * e1b * dbb
        g2 = e2v * e2v * dvv + 2 * e2v * e2b * dvb + e2b * e2b * dbb
        g3 = e3v * e3v * dvv + 2 * e3v * e3b * dvb + e3b * e3b * dbb
        cw = e1.qb * dbb  # ⟨q_b e_b e_bᵀ, D⟩ (HΛ = 0: only the w_{k−2} term)
        q = []
        for i in range(self.n):
            y0 = e0.z[i] - e0.U[i][0]
            y1 = e1.z[i]
            w0 = e1.z[i] - e1.U[i][0]
            w1 = e2.z[i]
            p0 = j00 * w0 + j01 * w1  # M_o,k−1⁻¹ 𝒴_{k−1}
            p1 = j10 * w0 + j11 * w1
            zv = k00 * y0 + k01 * y1 - (p0 - Bv1 * p1) - e1.U[i][0]
            zb = k10 * y0 + k11 * y1 - beta1 * p1 - e1.U[i][1]
            zdz = zv * zv * dvv + 2 * zv * zb * dvb + zb * zb * dbb
            q.append(zdz - cw - (e0.R[i] * g1 + e1.R[i] * g2 + e2.R[i] * g3))
        self.matching.add(q, dvv * dvv + 2 * dvb * dvb + dbb * dbb)
        return True

    def _accept(self) -> None:
        """The Ŝ_v used: least squares floored at its standard error (``se_floor``), or the last positive estimate."""
        if self.count < self.min_samples or self.matching.den <= 0.0:
            return
        if self.pd_check == "se_floor":
            self._S, kept = self.matching.working(self._S, self._prior)
            self.rejected += int(kept > 0)
            return
        new = self.matching.values()
        ok = [math.isfinite(x) and x > 0 for x in new]
        if self.pd_check == "joint" and not all(ok):
            self.rejected += 1
            return
        for i in range(self.n):
            if ok[i]:
                self._S[i] = new[i]
        self.rejected += int(not all(ok))
