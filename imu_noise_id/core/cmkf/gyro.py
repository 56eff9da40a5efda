"""Gyro-bias filter analogous to paper 004's CMKF (beyond the paper; model and derivation: docs/cmkf.md, "Gyro"): per
IMU axis y_k/T_k = b_k + e_k, Var e_k = S_g/T_k + R_k/T_k², a scalar Joseph-form filter (27) and a covariance-matching
Ŝ_g [rad²/s] of d_k = y_k/T_k − φ y_{k−1}/T_{k−1} (cf. eqs. 28–35)."""

from __future__ import annotations

import math

import numpy as np

from .matching import MatchingLeastSquares


class GyroBiasFilter:
    """Per-axis gyro-bias filter (plain floats, the :class:`~.protocol.CmkfFilter` names): bias time constant ``tau``
    [s], steady-state σ ``sigma`` [rad/s], initial S_g ``s_g0`` [rad²/s], ``min_samples`` before Ŝ_g is used,
    ``pd_check`` ``"se_floor"`` or else the last positive value. ``x``, ``P``: bias [rad/s], variance [rad²/s²]."""

    def __init__(self, tau: float, sigma: float, s_g0: float, min_samples: int = 10, pd_check: str = "se_floor"
                 ) -> None:
        self.tau = float(tau)
        self.sigma = float(sigma)
        self.bias = [0.0, 0.0, 0.0]
        self.var = [self.sigma**2] * 3
        self._S = [float(s_g0)] * 3
        self._s_g0 = [float(s_g0)] * 3
        self.min_samples = int(min_samples)
        self.pd_check = pd_check
        self.matching = MatchingLeastSquares(3)
        self._nu = [math.nan] * 3
        self._s = [math.nan] * 3
        self._T = math.nan
        self._prev: tuple[list[float], float, list[float]] | None = None  # (y/T, T, R) of the last epoch

    @property
    def x(self) -> np.ndarray:
        return np.array(self.bias)

    @property
    def P(self) -> np.ndarray:
        return np.array(self.var)

    @property
    def y(self) -> np.ndarray:
        return np.array(self._nu)

    @property
    def S(self) -> np.ndarray:
        return np.array(self._s)

    @property
    def S_used(self) -> np.ndarray:
        return np.array(self._S)

    @property
    def count(self) -> int:
        return self.matching.count

    @property
    def S_ls(self) -> np.ndarray:
        return self.matching.estimate

    def reset_chain(self) -> None:
        """Do not difference across a gap."""
        self._prev = None

    def predicted_P(self, T: float) -> np.ndarray:
        """Bias variance after ``T`` seconds without an update."""
        phi2 = math.exp(-2.0 * T / self.tau)
        return np.array([phi2 * p + (1.0 - phi2) * self.sigma**2 for p in self.var])

    def predict(self, T: float) -> None:
        """The next update closes an odometry interval of ``T`` [s] (> 0)."""
        self._T = float(T)

    def _prior(self) -> tuple[float, float]:
        """(φ, q) of the pending interval."""
        phi = math.exp(-self._T / self.tau)
        return phi, (1.0 - phi * phi) * self.sigma**2

    def nis(self, z: list[float], R: list[float]) -> float:
        """NIS (3 dof) that :meth:`update` with ``z`` and ``R`` would have, without updating (the innovation gate)."""
        T = self._T
        phi, q = self._prior()
        total = 0.0
        for i in range(3):
            nu = z[i] / T - phi * self.bias[i]
            total += nu * nu / (phi * phi * self.var[i] + q + self._S[i] / T + R[i] / (T * T))
        return total

    def coast(self) -> None:
        """A rejected update: the bias is only predicted over the pending interval; no matching step spans it."""
        phi, q = self._prior()
        for i in range(3):
            self.bias[i] *= phi
            self.var[i] = phi * phi * self.var[i] + q
        self._prev = None

    def update(self, z: list[float], R: list[float], shared: list[float] | None = None) -> float:
        """Update with ``z`` = Δθ̃ − Δθ_odo [rad], ``R`` = Var Δθ_odo [rad²], ``shared`` its rate's covariance with the
        previous interval's [rad²/s²] (3 each); NIS summed over the axes (3 dof)."""
        T = self._T
        phi, q = self._prior()
        meas = [zi / T for zi in z]
        nis = 0.0
        for i in range(3):
            b_pred = phi * self.bias[i]
            P_pred = phi * phi * self.var[i] + q
            r = self._S[i] / T + R[i] / (T * T)
            s = P_pred + r
            K = P_pred / s
            nu = meas[i] - b_pred
            self.bias[i] = b_pred + K * nu
            self.var[i] = (1.0 - K) ** 2 * P_pred + K * K * r  # Joseph form (27), scalar
            self._nu[i], self._s[i] = nu, s
            nis += nu * nu / s
        if self._prev is not None:
            meas1, T1, R1 = self._prev
            D = 1.0 / T + phi * phi / T1
            products = []
            for i in range(3):
                d = meas[i] - phi * meas1[i]
                cross = 2.0 * phi * shared[i] if shared is not None else 0.0  # E[e_k e_{k-1}] enters with −2φ
                products.append((d * d - q - R[i] / (T * T) - phi * phi * R1[i] / (T1 * T1) + cross) * D)
            self.matching.add(products, D * D)
            if self.count >= self.min_samples:
                if self.pd_check == "se_floor":
                    self._S = self.matching.working(self._S, self._s_g0)[0]
                else:
                    for i, s_new in enumerate(self.matching.values()):
                        if s_new > 0:
                            self._S[i] = s_new
        self._prev = (meas, T, list(R))
        return nis
