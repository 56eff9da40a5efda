"""The IMU side of the robot CMKF: per-sample propagation (paper 004 eqs. 3–4, 13–16) and the interval of
T = Σ dt_j it forms, eqs. (13)–(16), (22) accumulated exactly into F̂, Q_a, q_b (docs/cmkf.md, "From the table to a
robot"; one sample gives eq. 17, :func:`~.axis.paper_interval`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from . import rotation as rot
from .stacked import Interval


@dataclass(frozen=True)
class ImuInterval:
    """One interval (eqs. 17, 22–23): ``T`` [s]; F̂[0, 2] = −``Bp``, F̂[1, 2] = −``Bv``; ``phi`` = Π φ_j; ``Qrr``, ``Qrv``
    of Q_a for S_v = 1 (velocity variance T); ``qb`` bias-drive variance (eq. 7) [m²/s⁴]."""

    T: float
    Bp: float
    Bv: float
    phi: float
    Qrr: float
    Qrv: float
    qb: float

    @cached_property
    def Phi(self) -> np.ndarray:
        """F̂ of ``[r, v, b]`` (eq. 17 with the bias input folded in)."""
        return np.array([[1.0, self.T, -self.Bp], [0.0, 1.0, -self.Bv], [0.0, 0.0, self.phi]])

    @cached_property
    def Qa1(self) -> np.ndarray:
        """Covariance of the velocity-random-walk effect on ``[r, v, b]`` for S_v = 1 [m²/s³] (eqs. 22–23)."""
        return np.array([[self.Qrr, self.Qrv, 0.0], [self.Qrv, self.T, 0.0], [0.0, 0.0, 0.0]])

    def matrices(self, sub: slice) -> Interval:
        """The interval of the sub-state ``sub`` of ``[r, v, b]`` for the stacked estimator."""
        return Interval(self.Phi[sub, sub], self.Qa1[sub, sub], self.qb)


class ImuPropagation:
    """The accelerometer filter's state between two epochs, per IMU sample (plain floats): r̂, v̂, b̂, Δp_n (with
    ``track_position``), ∫ω̃ dt, q_ni and the sums of :meth:`interval`; ``gravity`` [m/s²], ``bias_tau`` [s],
    ``bias_sigma`` [m/s²] of the accelerometer bias."""

    def __init__(self, gravity: float, bias_tau: float, bias_sigma: float, track_position: bool) -> None:
        self._g = gravity
        self._phi_per_s = 1.0 / bias_tau
        self._sigma2 = bias_sigma**2
        self.track_position = track_position
        self.r = [0.0, 0.0, 0.0]
        self.v = [0.0, 0.0, 0.0]
        self.b = [0.0, 0.0, 0.0]
        self.q_ni: rot.Quat | None = None
        self.reset_interval()

    def reset_interval(self) -> None:
        """Start a new interval (after a measurement epoch)."""
        self.T = 0.0
        self._beta = 1.0
        self._M0 = self._M1 = self._N1 = self._N2 = 0.0
        self.dtheta = [0.0, 0.0, 0.0]
        self.dp = [0.0, 0.0, 0.0]

    def interval(self) -> ImuInterval:
        """The interval accumulated since the last epoch."""
        T, M0, M1, N1, N2, beta = self.T, self._M0, self._M1, self._N1, self._N2, self._beta
        return ImuInterval(T, T * M0 - M1, M0, beta, T**3 - 2.0 * T * N1 + N2, T * T - N1,
                           (1.0 - beta**2) * self._sigma2)

    def step(self, dt: float, sample: tuple[float, ...], gyro_bias: list[float], q_gravity: rot.Quat | None) -> None:
        """Eqs. (13)–(16) per axis for ``sample`` (gyro [rad/s], accel [m/s²]) held over ``dt``; ``q_gravity`` the IMU
        orientation gravity is removed with (None: level)."""
        wx, wy, wz, fx, fy, fz = sample
        ox, oy, oz = wx - gyro_bias[0], wy - gyro_bias[1], wz - gyro_bias[2]
        dtheta = self.dtheta
        dtheta[0] += wx * dt
        dtheta[1] += wy * dt
        dtheta[2] += wz * dt
        x, y, z, w = q_gravity if q_gravity is not None else rot.IDENTITY
        g = self._g  # g_i = C_ni^T [0, 0, -g] = -g * (third row of C_ni)
        gx, gy, gz = -g * 2 * (x * z - y * w), -g * 2 * (y * z + x * w), -g * (1 - 2 * (x * x + y * y))
        v, b = self.v, self.b
        ux = fx + gx - (oy * v[2] - oz * v[1])
        uy = fy + gy - (oz * v[0] - ox * v[2])
        uz = fz + gz - (ox * v[1] - oy * v[0])
        ax, ay, az = ux - b[0], uy - b[1], uz - b[2]
        h = 0.5 * dt * dt
        q_ni = self.q_ni
        if self.track_position and q_ni is not None:
            # eq. (13) displacement, accumulated in the odometry frame (rotated back at the epoch)
            dx, dy, dz = v[0] * dt + ax * h, v[1] * dt + ay * h, v[2] * dt + az * h
            qx, qy, qz, qw = q_ni
            tx, ty, tz = 2 * (qy * dz - qz * dy), 2 * (qz * dx - qx * dz), 2 * (qx * dy - qy * dx)
            dp = self.dp
            dp[0] += dx + qw * tx + qy * tz - qz * ty
            dp[1] += dy + qw * ty + qz * tx - qx * tz
            dp[2] += dz + qw * tz + qx * ty - qy * tx
        v[0] += ax * dt
        v[1] += ay * dt
        v[2] += az * dt
        phi = math.exp(-dt * self._phi_per_s)
        b[0] *= phi
        b[1] *= phi
        b[2] *= phi
        m = self.T + 0.5 * dt
        bd = self._beta * dt
        self._M0 += bd
        self._M1 += bd * m
        self._N1 += dt * m
        self._N2 += dt * m * m
        self._beta *= phi
        self.T += dt
        if q_ni is not None:
            # q_ni ← q_ni ⊗ exp(ω̂ dt / 2), first order in the half angle, renormalised
            hx, hy, hz = 0.5 * ox * dt, 0.5 * oy * dt, 0.5 * oz * dt
            qx, qy, qz, qw = q_ni
            nx = qx + qw * hx + qy * hz - qz * hy
            ny = qy + qw * hy + qz * hx - qx * hz
            nz = qz + qw * hz + qx * hy - qy * hx
            nw = qw - qx * hx - qy * hy - qz * hz
            n = 1.0 / math.sqrt(nx * nx + ny * ny + nz * nz + nw * nw)
            self.q_ni = (nx * n, ny * n, nz * n, nw * n)
