"""Simulated ground robot with a rotated IMU and wheel-odometry-like messages (truth for the robot CMKF tests).

The robot drives on flat ground (z up) with forward speed ``s(t) = s0 + s1 sin(2πt/P_s)`` and yaw rate
``ω(t) = w1 sin(2πt/P_1) + w2 sin(2πt/P_2)`` (no side slip). In the base frame the acceleration is
``a_b = [ṡ, s ω, 0]``, the specific force ``f_b = a_b + [0, 0, g]``, the angular rate ``[0, 0, ω]``. The IMU, mounted
with rotation ``C_bi``, reports per sample the *average* of the true specific force and rate over its period (an
integrating sensor, paper 004 eq. 10) plus constant biases and white noise of PSD ``S_v`` [m²/s³] and ``S_g``
[rad²/s]. Odometry reports the true body velocity and yaw rate with white noise, the yaw orientation and the
position (integrated on the fine grid).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..cmkf import rotation as rot


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


def simulate_robot(
    duration: float,
    rng: np.random.Generator,
    *,
    imu_rate: float = 100.0,
    odom_rate: float = 10.0,
    S_v: float = 1e-4,
    S_g: float = 1e-6,
    accel_bias: tuple[float, float, float] = (0.05, -0.08, 0.03),
    gyro_bias: tuple[float, float, float] = (0.002, -0.003, 0.001),
    velocity_noise_std: float = 0.002,
    angular_velocity_noise_std: float = 0.002,
    position_noise_std: float = 0.002,
    imu_rotation_xyzw: tuple[float, float, float, float] | None = None,
    gravity: float = 9.80665,
    substeps: int = 10,
) -> RobotRun:
    """Simulate ``duration`` seconds (see module docstring); default IMU rotation = the Husky bag's (y up)."""
    q_bi = imu_rotation_xyzw or rot.from_ypr(-np.pi / 2, 0.0, np.pi / 2)
    C_ib = rot.to_matrix(rot.normalise(q_bi)).T
    dt = 1.0 / imu_rate
    n = round(duration * imu_rate)
    # Fine grid: `substeps` midpoints per IMU period, averaged into each sample over (t_{k-1}, t_k].
    tf = (np.arange(n * substeps) + 0.5) * (dt / substeps)
    s0, s1, ps = 0.6, 0.4, 17.0
    w1, p1, w2, p2 = 0.5, 23.0, 0.2, 7.0
    s = s0 + s1 * np.sin(2 * np.pi * tf / ps)
    sdot = s1 * 2 * np.pi / ps * np.cos(2 * np.pi * tf / ps)
    w = w1 * np.sin(2 * np.pi * tf / p1) + w2 * np.sin(2 * np.pi * tf / p2)
    f_b = np.column_stack([sdot, s * w, np.full_like(tf, gravity)])
    w_b = np.column_stack([np.zeros_like(tf), np.zeros_like(tf), w])
    f_i = (f_b @ C_ib.T).reshape(n, substeps, 3).mean(axis=1)
    w_i = (w_b @ C_ib.T).reshape(n, substeps, 3).mean(axis=1)
    imu_t = (np.arange(n) + 1) * dt
    accel = f_i + np.asarray(accel_bias) + rng.normal(0.0, np.sqrt(S_v / dt), size=(n, 3))
    gyro = w_i + np.asarray(gyro_bias) + rng.normal(0.0, np.sqrt(S_g / dt), size=(n, 3))

    def yaw(t: np.ndarray) -> np.ndarray:
        return -w1 * p1 / (2 * np.pi) * np.cos(2 * np.pi * t / p1) - w2 * p2 / (2 * np.pi) * np.cos(2 * np.pi * t / p2)

    m = int(np.floor(duration * odom_rate))
    odom_t = (np.arange(m) + 1) / odom_rate
    psi = yaw(odom_t)
    so = s0 + s1 * np.sin(2 * np.pi * odom_t / ps)
    wo = w1 * np.sin(2 * np.pi * odom_t / p1) + w2 * np.sin(2 * np.pi * odom_t / p2)
    # Position by trapezoid integration of the nav-frame velocity on a grid 10x finer than the IMU.
    tg = np.linspace(0.0, duration, n * substeps + 1)
    vg = (s0 + s1 * np.sin(2 * np.pi * tg / ps))[:, None] * np.column_stack([np.cos(yaw(tg)), np.sin(yaw(tg))])
    pg = np.vstack([np.zeros(2), np.cumsum(0.5 * (vg[1:] + vg[:-1]) * np.diff(tg)[:, None], axis=0)])
    pos_xy = np.column_stack([np.interp(odom_t, tg, pg[:, 0]), np.interp(odom_t, tg, pg[:, 1])])
    position = np.column_stack([pos_xy, np.zeros(m)]) + rng.normal(0.0, position_noise_std, size=(m, 3))
    quat = np.column_stack([np.zeros(m), np.zeros(m), np.sin(psi / 2), np.cos(psi / 2)])
    lin = np.column_stack([so, np.zeros(m), np.zeros(m)]) + rng.normal(0.0, velocity_noise_std, size=(m, 3))
    ang = np.column_stack([np.zeros(m), np.zeros(m), wo]) + rng.normal(0.0, angular_velocity_noise_std, size=(m, 3))
    pose_cov = np.zeros((m, 6, 6))
    twist_cov = np.zeros((m, 6, 6))
    for i in range(3):
        pose_cov[:, i, i] = position_noise_std**2
        pose_cov[:, 3 + i, 3 + i] = 1e-6
        twist_cov[:, i, i] = velocity_noise_std**2
        twist_cov[:, 3 + i, 3 + i] = angular_velocity_noise_std**2
    return RobotRun(
        imu_t, gyro, accel, odom_t, position, quat, lin, ang, pose_cov, twist_cov,
        np.asarray(accel_bias, float), np.asarray(gyro_bias, float), tuple(q_bi),
    )


def replay_arrays(filt: object, run: RobotRun) -> list:
    """Feed a :class:`RobotRun` to a streaming filter in stamp order; returns the estimate after each odometry."""
    out = []
    i = j = 0
    ni, nj = len(run.imu_t), len(run.odom_t)
    while i < ni or j < nj:
        if j >= nj or (i < ni and run.imu_t[i] <= run.odom_t[j]):
            filt.process_imu(run.imu_t[i], run.gyro[i], run.accel[i])
            i += 1
        else:
            filt.process_odometry(
                run.odom_t[j], position=run.position[j], orientation_xyzw=run.orientation_xyzw[j],
                linear_velocity=run.linear_velocity[j], angular_velocity=run.angular_velocity[j],
                pose_cov=run.pose_cov[j], twist_cov=run.twist_cov[j],
            )
            out.append(filt.estimate())
            j += 1
    return out
