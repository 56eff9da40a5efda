"""A simulated ground robot that stands, drives and stands again: IMU and wheel-odometry truth for the node.

The robot moves on flat ground (z up). During the drive of length ``D`` its forward speed is
``s(τ) = V·w(τ)`` and its yaw rate ``ω(τ) = W·sin(2πτ/P)·w(τ)`` with the window ``w(τ) = sin²(πτ/D)`` (smooth
start and stop, no side slip); before and after it stands still. In the base frame the acceleration is
``a_b = [ṡ, s·ω, 0]``, the specific force ``f_b = a_b + [0, 0, g]`` and the angular rate ``[0, 0, ω]``. The IMU,
mounted with rotation ``C_bi``, reports the average of the true values over each sample period (computed on a
grid ``substeps`` times finer), plus constant biases, white noise of density ``N`` (per-sample standard deviation
``N/√Δt``) and, optionally, a bias random walk of density ``K`` (:class:`~imu_noise_id.core.noise.components.RW`).
Odometry reports the true body velocity and yaw rate with white noise, the yaw orientation and the integrated
position. The result is a :class:`~imu_noise_id.core.simulation.robot.RobotRun`.
"""

from __future__ import annotations

import math

import numpy as np

from ..cmkf import rotation as rot
from ..noise.components import RW
from .robot import RobotRun
from .static import STANDARD_GRAVITY


def simulate_stop_and_go(
    rng: np.random.Generator,
    *,
    stand_before: float = 20.0,
    drive: float = 30.0,
    stand_after: float = 20.0,
    imu_rate: float = 200.0,
    odom_rate: float = 50.0,
    speed: float = 1.0,
    yaw_rate: float = 0.5,
    yaw_period: float = 10.0,
    gyro_noise_density: float = 1e-3,
    accel_noise_density: float = 1e-2,
    gyro_random_walk: float = 0.0,
    accel_random_walk: float = 0.0,
    gyro_bias: tuple[float, float, float] = (0.004, -0.006, 0.003),
    accel_bias: tuple[float, float, float] = (0.08, -0.05, 0.06),
    velocity_noise_std: float = 0.005,
    angular_velocity_noise_std: float = 0.005,
    imu_rotation_xyzw: tuple[float, float, float, float] = rot.IDENTITY,
    t0: float = 1000.0,
    substeps: int = 8,
    gravity: float = STANDARD_GRAVITY,
) -> RobotRun:
    """Simulate one stand–drive–stand run (see the module docstring); times start at ``t0`` [s].

    Raises
    ------
    ValueError
        On non-positive rates or a total duration shorter than two IMU periods.
    """
    if not (imu_rate > 0 and odom_rate > 0 and substeps >= 1):
        raise ValueError(f"rates must be > 0 Hz and substeps >= 1, got {imu_rate}, {odom_rate}, {substeps}")
    duration = stand_before + drive + stand_after
    n = round(duration * imu_rate)
    if n < 2:
        raise ValueError(f"duration {duration} s at {imu_rate} Hz gives fewer than two IMU samples")
    dt = 1.0 / imu_rate
    C_ib = rot.to_matrix(rot.normalise(imu_rotation_xyzw)).T

    def motion(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Speed, its derivative and the yaw rate at times t (relative to the start)."""
        tau = t - stand_before
        moving = (tau > 0) & (tau < drive)
        window = np.where(moving, np.sin(math.pi * tau / drive) ** 2, 0.0) if drive > 0 else np.zeros_like(t)
        dwindow = (np.where(moving, math.pi / drive * np.sin(2 * math.pi * tau / drive), 0.0)
                   if drive > 0 else np.zeros_like(t))
        s = speed * window
        sdot = speed * dwindow
        w = yaw_rate * np.sin(2 * math.pi * tau / yaw_period) * window
        return s, sdot, w

    tf = (np.arange(n * substeps) + 0.5) * (dt / substeps)
    s, sdot, w = motion(tf)
    f_b = np.column_stack([sdot, s * w, np.full_like(tf, gravity)])
    w_b = np.column_stack([np.zeros_like(tf), np.zeros_like(tf), w])
    f_i = (f_b @ C_ib.T).reshape(n, substeps, 3).mean(axis=1)
    w_i = (w_b @ C_ib.T).reshape(n, substeps, 3).mean(axis=1)
    gyro = w_i + np.asarray(gyro_bias) + rng.normal(0.0, gyro_noise_density / math.sqrt(dt), (n, 3))
    accel = f_i + np.asarray(accel_bias) + rng.normal(0.0, accel_noise_density / math.sqrt(dt), (n, 3))
    for k in range(3):
        if gyro_random_walk > 0:
            gyro[:, k] += RW(gyro_random_walk).simulate(n, dt, rng)
        if accel_random_walk > 0:
            accel[:, k] += RW(accel_random_walk).simulate(n, dt, rng)
    imu_t = t0 + (np.arange(n) + 1) * dt

    # Yaw and position on the fine grid (trapezoid), sampled at the odometry stamps.
    tg = np.linspace(0.0, duration, n * substeps + 1)
    sg, _, wg = motion(tg)
    steps = np.diff(tg)
    yaw = np.concatenate([[0.0], np.cumsum(0.5 * (wg[1:] + wg[:-1]) * steps)])
    vg = sg[:, None] * np.column_stack([np.cos(yaw), np.sin(yaw)])
    pg = np.vstack([np.zeros(2), np.cumsum(0.5 * (vg[1:] + vg[:-1]) * steps[:, None], axis=0)])
    m = math.floor(duration * odom_rate)
    odom_rel = (np.arange(m) + 1) / odom_rate
    so, _, wo = motion(odom_rel)
    psi = np.interp(odom_rel, tg, yaw)
    position = np.column_stack([np.interp(odom_rel, tg, pg[:, 0]), np.interp(odom_rel, tg, pg[:, 1]), np.zeros(m)])
    quat = np.column_stack([np.zeros(m), np.zeros(m), np.sin(psi / 2), np.cos(psi / 2)])
    lin = np.column_stack([so, np.zeros(m), np.zeros(m)]) + rng.normal(0.0, velocity_noise_std, (m, 3))
    ang = np.column_stack([np.zeros(m), np.zeros(m), wo]) + rng.normal(0.0, angular_velocity_noise_std, (m, 3))
    pose_cov = np.zeros((m, 6, 6))
    twist_cov = np.zeros((m, 6, 6))
    for i in range(3):
        pose_cov[:, i, i] = 1e-4
        pose_cov[:, 3 + i, 3 + i] = 1e-4
        twist_cov[:, i, i] = velocity_noise_std**2
        twist_cov[:, 3 + i, 3 + i] = angular_velocity_noise_std**2
    return RobotRun(
        imu_t, gyro, accel, t0 + odom_rel, position, quat, lin, ang, pose_cov, twist_cov,
        np.asarray(accel_bias, float), np.asarray(gyro_bias, float), tuple(imu_rotation_xyzw),
    )
