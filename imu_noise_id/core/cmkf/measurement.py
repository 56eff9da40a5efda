"""The odometry side of the robot CMKF: nav_msgs/Odometry → measurements per IMU axis (paper 004 eq. 8 on a robot;
docs/cmkf.md, "From the table to a robot"): twist z_v = C_ibᵀ v_b (REP-105), pose_twist also z_r = C_in (p_n −
p_anchor); R the rotated covariance's diagonal (or a parameter); the gyro filter's rotation over an interval."""

from __future__ import annotations

import math

import numpy as np

from . import rotation as rot
from .config import CmkfConfig

#: Vector fields of an odometry message and their lengths.
FIELDS = {"position": 3, "orientation_xyzw": 4, "linear_velocity": 3, "angular_velocity": 3}


def _as_floats(a: np.ndarray | list[float] | tuple[float, ...]) -> list[float]:
    """A message vector as a list of floats (cheap for the 1-D arrays the node and the replay pass)."""
    if isinstance(a, np.ndarray):
        return a.astype(float, copy=False).ravel().tolist()
    return [float(x) for x in a]


def _rotate(rows: tuple[tuple[float, float, float], ...], v: list[float]) -> list[float]:
    """``C v`` with C given by its rows (plain floats)."""
    return [r[0] * v[0] + r[1] * v[1] + r[2] * v[2] for r in rows]


class _CovDiag:
    """Per-axis diag(C Σ Cᵀ) of a 3×3 block of a 6×6 covariance, cached; None when unknown (zeros, −1, NaN)."""

    def __init__(self, block: slice) -> None:
        self.block = block
        self._key: bytes | None = None
        self._value: list[float] | None = None

    def __call__(self, cov: np.ndarray | None, C: np.ndarray) -> list[float] | None:
        cov = None if cov is None else np.asarray(cov, dtype=float)
        if cov is None or cov.size != 36:
            return None
        sub = cov.reshape(6, 6)[self.block, self.block]
        key = sub.tobytes() + C.tobytes()
        if key != self._key:
            self._key = key
            ok = np.all(np.isfinite(sub)) and sub[0, 0] >= 0 and np.any(sub)
            self._value = np.einsum("ij,jk,ik->i", C, sub, C).tolist() if ok else None
        return self._value


class TwistMeasurement:
    """Body velocity per IMU axis (m = 1); ``config``: noise overrides and defaults; ``C_ib``: base → IMU rotation."""

    m = 1

    def __init__(self, config: CmkfConfig, C_ib: np.ndarray) -> None:
        self.config = config
        self.C_ib = C_ib
        self._C_ib_rows = tuple(tuple(float(c) for c in row) for row in C_ib)
        self._twist_lin_cov = _CovDiag(slice(0, 3))
        self._twist_ang_cov = _CovDiag(slice(3, 6))
        self._w_prev: tuple[list[float], list[float]] | None = None  # twist rate and its variance, last epoch
        self._q_nb_prev: rot.Quat | None = None
        self.needs = ("linear_velocity", "orientation_xyzw") if config.gravity_source == "odometry" else (
            "linear_velocity",)

    @staticmethod
    def values(fields: dict[str, object]) -> tuple[dict[str, list[float] | None], rot.Quat | None, bool] | None:
        """Float lists, unit quaternion and whether an orientation was unusable (REP-145 zero or non-finite: then None);
        None if another field is NaN/inf or malformed."""
        vals = {k: None if a is None else _as_floats(a) for k, a in fields.items()}
        if any(a is not None and len(a) != FIELDS[k] for k, a in vals.items()):
            return None
        q_nb = None
        invalid = False
        if vals["orientation_xyzw"] is not None:
            try:
                q_nb = rot.normalise(vals["orientation_xyzw"])
            except ValueError:  # zero or non-finite quaternion: no orientation
                vals["orientation_xyzw"] = None
                invalid = True
        # NaN/inf anywhere makes the sum non-finite (values near 1e308 are absurd here anyway)
        if not math.isfinite(sum(sum(a) for a in vals.values() if a is not None)):
            return None
        return vals, q_nb, invalid

    def missing(self, vals: dict[str, list[float] | None]) -> bool:
        """True when a field this measurement needs is absent."""
        return any(vals[k] is None for k in self.needs)

    def measure(self, vals: dict[str, list[float] | None], q_ni: rot.Quat | None, pose_cov: np.ndarray | None,
                twist_cov: np.ndarray | None) -> tuple[list, list]:
        """``z`` (3, 1) and ``R`` (3, 1, 1) per IMU axis: the body velocity in IMU axes."""
        zv, rv = self._velocity(vals, twist_cov)
        return [[v] for v in zv], [[[r]] for r in rv]

    def _velocity(self, vals: dict[str, list[float] | None], twist_cov: np.ndarray | None
                  ) -> tuple[list[float], list[float]]:
        cfg = self.config
        zv = _rotate(self._C_ib_rows, vals["linear_velocity"])
        if cfg.velocity_noise_std is not None:
            return zv, [cfg.velocity_noise_std**2] * 3
        rv = self._twist_lin_cov(twist_cov, self.C_ib)
        return zv, [cfg.default_velocity_noise_std**2] * 3 if rv is None else rv

    def position_prior(self, r: list[float], dp: list[float]) -> list[float]:
        """r̂⁻ of the epoch: the position is not measured, so it is carried unchanged."""
        return r

    @staticmethod
    def initial(z: list, R: list) -> tuple[list[float], list[float], list[float], list[float]]:
        """(r₀, v₀, P_rr,0, P_vv,0) per axis from the first measurement (r is not tracked: 0 ± 1)."""
        return [0.0] * 3, [v[0] for v in z], [1.0] * 3, [r[0][0] for r in R]

    def rotation_increment(self, vals: dict[str, list[float] | None], q_nb: rot.Quat | None,
                           twist_cov: np.ndarray | None, T: float, new_chain: bool
                           ) -> tuple[list[float], list[float], list[float]] | None:
        """Odometry rotation over ``T`` in IMU axes [rad], its variance [rad²], covariance of its rate with the previous
        interval's [rad²/s²] (¼ Var ω_{k−1}, trapezoid; 0, orientations); None when it cannot be formed."""
        cfg = self.config
        if vals["angular_velocity"] is not None:
            w_now = _rotate(self._C_ib_rows, vals["angular_velocity"])
            if cfg.angular_velocity_noise_std is not None:
                rw = [cfg.angular_velocity_noise_std**2] * 3
            else:
                rw = self._twist_ang_cov(twist_cov, self.C_ib)
                rw = [cfg.default_angular_velocity_noise_std**2] * 3 if rw is None else rw
            prev, self._w_prev = self._w_prev, (w_now, rw)
            if prev is None or new_chain:
                return None  # the trapezoid needs the rate at both ends of the interval
            # trapezoid: the twist is the rate at the stamp
            return ([0.5 * (a + b) * T for a, b in zip(prev[0], w_now, strict=True)],
                    [0.25 * (a + b) * T * T for a, b in zip(prev[1], rw, strict=True)],
                    [0.25 * a for a in prev[1]])
        if q_nb is not None and self._q_nb_prev is not None:
            dq = rot.multiply(rot.conjugate(self._q_nb_prev), q_nb)
            std = cfg.angular_velocity_noise_std or cfg.default_angular_velocity_noise_std
            return _rotate(self._C_ib_rows, rot.to_rotvec(dq).tolist()), [(std * T) ** 2] * 3, [0.0] * 3
        return None

    def reset_chain(self) -> None:
        """Forget the last epoch's rate and orientation (a new time line: no increment spans it)."""
        self._w_prev = None
        self._q_nb_prev = None

    def end_epoch(self, q_nb: rot.Quat | None) -> None:
        """The epoch is processed: remember its orientation for the next one."""
        if q_nb is not None:
            self._q_nb_prev = q_nb


class PoseTwistMeasurement(TwistMeasurement):
    """Position in the odometry frame and body velocity per IMU axis (m = 2, paper 004's eq. 8)."""

    m = 2

    def __init__(self, config: CmkfConfig, C_ib: np.ndarray) -> None:
        super().__init__(config, C_ib)
        self.needs = ("position", "orientation_xyzw", "linear_velocity")
        self._pose_cov = _CovDiag(slice(0, 3))
        self._anchor: np.ndarray | None = None
        self._C_ni: np.ndarray | None = None  # orientation of the epoch being processed
        self._C_ni_epoch: np.ndarray | None = None  # and of the last one

    def measure(self, vals: dict[str, list[float] | None], q_ni: rot.Quat | None, pose_cov: np.ndarray | None,
                twist_cov: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """``z`` (3, 2) and ``R`` (3, 2, 2) per IMU axis: position from the first one, and body velocity."""
        cfg = self.config
        zv, rv = self._velocity(vals, twist_cov)
        p = np.array(vals["position"])
        if self._anchor is None:
            self._anchor = p.copy()
        self._C_ni = rot.to_matrix(q_ni)
        C_in = self._C_ni.T
        zr = C_in @ (p - self._anchor)
        if cfg.position_noise_std is not None:
            rr = np.full(3, cfg.position_noise_std**2)
        else:
            rr = self._pose_cov(pose_cov, C_in)
            if rr is None:
                rr = np.full(3, cfg.default_position_noise_std**2)
        z = np.column_stack([zr, zv])
        R = np.zeros((3, 2, 2))
        R[:, 0, 0] = rr
        R[:, 1, 1] = rv
        return z, R

    def position_prior(self, r: list[float], dp: list[float]) -> list[float]:
        """r̂⁻_k = C_in,k (C_ni,k−1 r̂⁺_{k−1} + Δp_n): the displacement accumulated in the odometry frame."""
        return list(self._C_ni.T @ (self._C_ni_epoch @ np.array(r) + np.array(dp)))

    @staticmethod
    def initial(z: np.ndarray, R: np.ndarray) -> tuple[list[float], list[float], list[float], list[float]]:
        """(r₀, v₀, P_rr,0, P_vv,0) per axis from the first measurement."""
        return list(z[:, 0]), list(z[:, 1]), list(R[:, 0, 0]), list(R[:, 1, 1])

    def end_epoch(self, q_nb: rot.Quat | None) -> None:
        super().end_epoch(q_nb)
        self._C_ni_epoch = self._C_ni
