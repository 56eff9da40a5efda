"""Simulated ground robot with a rotated IMU and wheel odometry (truth for the CMKF, the node, the demo): flat
ground, speed s(t) and yaw rate ω(t) of a :class:`Motion`, no side slip, f_b = [ṡ, s ω, g], rate [0, 0, ω]; the IMU
(C_bi) reports their means over its period (paper 004 eq. 10; ``substeps`` finer grid) plus :class:`RobotSensors`
errors; odometry: true velocity and yaw rate with white noise, yaw, integrated position."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..axes import ImuSeries, OdometrySeries
from ..cmkf import rotation as rot
from ..cmkf.robot import CmkfEstimate, RobotCmkf
from ..cmkf.stream import feed_recording
from ..constants import STANDARD_GRAVITY
from ..noise.components import RW


@dataclass
class RobotRun:
    """Arrays of one simulated run (times in s, SI units)."""

    imu_t: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    odom_t: np.ndarray
    position: np.ndarray
    orientation_xyzw: np.ndarray
    linear_velocity: np.ndarray
    angular_velocity: np.ndarray
    pose_cov: np.ndarray
    twist_cov: np.ndarray
    accel_bias: np.ndarray
    gyro_bias: np.ndarray
    imu_rotation_xyzw: tuple[float, float, float, float]


class Motion(Protocol):
    """A motion profile: forward speed and yaw rate over time (from the start of the run) and the heading."""

    def speeds(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Forward speed ``s`` [m/s], its derivative [m/s²] and yaw rate ``ω`` [rad/s] at times ``t`` [s]."""

    def yaw_on_grid(self, grid: np.ndarray, yaw_rate: np.ndarray) -> np.ndarray:
        """Heading [rad] on the fine time grid, given the yaw rate on it."""

    def yaw_at(self, t: np.ndarray, grid: np.ndarray, grid_yaw: np.ndarray) -> np.ndarray:
        """Heading [rad] at times ``t``, given the heading on the fine grid."""


@dataclass(frozen=True)
class Weaving:
    """Always moving: ``s = s0 + s1 sin(2πt/ps)`` [m/s], ``ω = w1 sin(2πt/p1) + w2 sin(2πt/p2)`` [rad/s]."""

    s0: float = 0.6
    s1: float = 0.4
    ps: float = 17.0
    w1: float = 0.5
    p1: float = 23.0
    w2: float = 0.2
    p2: float = 7.0

    def speeds(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        s = self.s0 + self.s1 * np.sin(2 * np.pi * t / self.ps)
        sdot = self.s1 * 2 * np.pi / self.ps * np.cos(2 * np.pi * t / self.ps)
        w = self.w1 * np.sin(2 * np.pi * t / self.p1) + self.w2 * np.sin(2 * np.pi * t / self.p2)
        return s, sdot, w

    def _yaw(self, t: np.ndarray) -> np.ndarray:
        return (-self.w1 * self.p1 / (2 * np.pi) * np.cos(2 * np.pi * t / self.p1)
                - self.w2 * self.p2 / (2 * np.pi) * np.cos(2 * np.pi * t / self.p2))

    def yaw_on_grid(self, grid: np.ndarray, yaw_rate: np.ndarray) -> np.ndarray:
        return self._yaw(grid)

    def yaw_at(self, t: np.ndarray, grid: np.ndarray, grid_yaw: np.ndarray) -> np.ndarray:
        return self._yaw(t)


@dataclass(frozen=True)
class StopAndGo:
    """Stand ``stand_before`` s, drive ``drive`` s (``speed`` [m/s], ``yaw_rate`` [rad/s], sin² window), stand."""

    stand_before: float = 20.0
    drive: float = 30.0
    speed: float = 1.0
    yaw_rate: float = 0.5
    yaw_period: float = 10.0

    def speeds(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        drive = self.drive
        tau = t - self.stand_before
        moving = (tau > 0) & (tau < drive)
        window = np.where(moving, np.sin(math.pi * tau / drive) ** 2, 0.0) if drive > 0 else np.zeros_like(t)
        dwindow = (np.where(moving, math.pi / drive * np.sin(2 * math.pi * tau / drive), 0.0)
                   if drive > 0 else np.zeros_like(t))
        w = self.yaw_rate * np.sin(2 * math.pi * tau / self.yaw_period) * window
        return self.speed * window, self.speed * dwindow, w

    def yaw_on_grid(self, grid: np.ndarray, yaw_rate: np.ndarray) -> np.ndarray:
        """Trapezoid integral of ω on the grid, from 0."""
        return np.concatenate([[0.0], np.cumsum(0.5 * (yaw_rate[1:] + yaw_rate[:-1]) * np.diff(grid))])

    def yaw_at(self, t: np.ndarray, grid: np.ndarray, grid_yaw: np.ndarray) -> np.ndarray:
        return np.interp(t, grid, grid_yaw)


@dataclass(frozen=True)
class RobotSensors:
    """What the simulated sensors add to the truth (SI units).

    Attributes
    ----------
    accel_bias, gyro_bias : constant biases [m/s²], [rad/s]; S_v, S_g : white-noise PSD [m²/s³], [rad²/s] (σ = √(S/Δt))
    accel_random_walk, gyro_random_walk : bias random walks [m/s³/√Hz], [rad/s²/√Hz] (0: none)
    velocity_noise_std, angular_velocity_noise_std, position_noise_std : odometry white noise [m/s], [rad/s], [m]
    pose_variance : declared (position [m²], orientation [rad²]); imu_rotation_xyzw : C_bi; noise_order : draw order
    """

    accel_bias: tuple[float, float, float] = (0.05, -0.08, 0.03)
    gyro_bias: tuple[float, float, float] = (0.002, -0.003, 0.001)
    S_v: float = 1e-4
    S_g: float = 1e-6
    accel_random_walk: float = 0.0
    gyro_random_walk: float = 0.0
    velocity_noise_std: float = 0.002
    angular_velocity_noise_std: float = 0.002
    position_noise_std: float = 0.002
    pose_variance: tuple[float, float] | None = None
    imu_rotation_xyzw: tuple[float, float, float, float] | None = None
    noise_order: tuple[str, str] = ("accel", "gyro")


def simulate_robot(
    duration: float,
    rng: np.random.Generator,
    *,
    motion: Motion | None = None,
    sensors: RobotSensors | None = None,
    imu_rate: float = 100.0,
    odom_rate: float = 10.0,
    t0: float = 0.0,
    substeps: int = 10,
    gravity: float = STANDARD_GRAVITY,
) -> RobotRun:
    """``duration`` s from ``t0`` [s] of ``motion`` (:class:`Weaving`) with ``sensors``; ValueError on bad rates or
    ``substeps``, an unknown ``noise_order`` or fewer than two IMU samples."""
    motion = motion or Weaving()
    sensors = sensors or RobotSensors()
    if not (imu_rate > 0 and odom_rate > 0 and substeps >= 1):
        raise ValueError(f"rates must be > 0 Hz and substeps >= 1, got {imu_rate}, {odom_rate}, {substeps}")
    if sorted(sensors.noise_order) != ["accel", "gyro"]:
        raise ValueError(f"noise_order must hold 'accel' and 'gyro', got {sensors.noise_order}")
    n = round(duration * imu_rate)
    if n < 2:
        raise ValueError(f"duration {duration} s at {imu_rate} Hz gives fewer than two IMU samples")
    q_bi = sensors.imu_rotation_xyzw or rot.from_ypr(-np.pi / 2, 0.0, np.pi / 2)
    C_ib = rot.to_matrix(rot.normalise(q_bi)).T
    dt = 1.0 / imu_rate
    # Fine grid: `substeps` midpoints per IMU period, averaged into each sample over (t_{k-1}, t_k].
    tf = (np.arange(n * substeps) + 0.5) * (dt / substeps)
    s, sdot, w = motion.speeds(tf)
    f_b = np.column_stack([sdot, s * w, np.full_like(tf, gravity)])
    w_b = np.column_stack([np.zeros_like(tf), np.zeros_like(tf), w])
    truth = {
        "accel": (f_b @ C_ib.T).reshape(n, substeps, 3).mean(axis=1) + np.asarray(sensors.accel_bias),
        "gyro": (w_b @ C_ib.T).reshape(n, substeps, 3).mean(axis=1) + np.asarray(sensors.gyro_bias),
    }
    psd = {"accel": sensors.S_v, "gyro": sensors.S_g}
    imu = {name: truth[name] + rng.normal(0.0, np.sqrt(psd[name] / dt), size=(n, 3)) for name in sensors.noise_order}
    for k in range(3):
        for name, density in (("gyro", sensors.gyro_random_walk), ("accel", sensors.accel_random_walk)):
            if density > 0:
                imu[name][:, k] += RW(density).simulate(n, dt, rng)
    imu_t = _whole_nanoseconds(t0 + (np.arange(n) + 1) * dt)

    # Heading and position on a grid as fine as the IMU's (trapezoid), sampled at the odometry stamps.
    grid = np.linspace(0.0, duration, n * substeps + 1)
    sg, _, wg = motion.speeds(grid)
    yaw = motion.yaw_on_grid(grid, wg)
    vg = sg[:, None] * np.column_stack([np.cos(yaw), np.sin(yaw)])
    pg = np.vstack([np.zeros(2), np.cumsum(0.5 * (vg[1:] + vg[:-1]) * np.diff(grid)[:, None], axis=0)])
    m = math.floor(duration * odom_rate)
    odom_rel = (np.arange(m) + 1) / odom_rate
    so, _, wo = motion.speeds(odom_rel)
    psi = motion.yaw_at(odom_rel, grid, yaw)
    position = np.column_stack([np.interp(odom_rel, grid, pg[:, 0]), np.interp(odom_rel, grid, pg[:, 1]), np.zeros(m)])
    if sensors.position_noise_std > 0:
        position = position + rng.normal(0.0, sensors.position_noise_std, size=(m, 3))
    quat = np.column_stack([np.zeros(m), np.zeros(m), np.sin(psi / 2), np.cos(psi / 2)])
    lin = np.column_stack([so, np.zeros(m), np.zeros(m)]) + rng.normal(0.0, sensors.velocity_noise_std, size=(m, 3))
    ang = np.column_stack([np.zeros(m), np.zeros(m), wo]) + rng.normal(0.0, sensors.angular_velocity_noise_std,
                                                                      size=(m, 3))
    pos_var, att_var = sensors.pose_variance or (sensors.position_noise_std**2, 1e-6)
    pose_cov = np.zeros((m, 6, 6))
    twist_cov = np.zeros((m, 6, 6))
    for i in range(3):
        pose_cov[:, i, i] = pos_var
        pose_cov[:, 3 + i, 3 + i] = att_var
        twist_cov[:, i, i] = sensors.velocity_noise_std**2
        twist_cov[:, 3 + i, 3 + i] = sensors.angular_velocity_noise_std**2
    return RobotRun(
        imu_t, imu["gyro"], imu["accel"], _whole_nanoseconds(t0 + odom_rel), position, quat, lin, ang, pose_cov,
        twist_cov,
        np.asarray(sensors.accel_bias, float), np.asarray(sensors.gyro_bias, float), tuple(q_bi),
    )


def _whole_nanoseconds(t: np.ndarray) -> np.ndarray:
    return np.round(t * 1e9) / 1e9


def replay_arrays(filt: RobotCmkf, run: RobotRun) -> list[CmkfEstimate]:
    """Feed a :class:`RobotRun` to a robot CMKF in stamp order; the estimate after each odometry message."""
    imu = ImuSeries(run.imu_t, run.gyro, run.accel)
    odom = OdometrySeries(run.odom_t, run.position, run.orientation_xyzw, run.linear_velocity, run.angular_velocity,
                          run.pose_cov, run.twist_cov)
    return [filt.estimate() for _ in feed_recording(filt, imu, odom)]
