"""The robot CMKF's parameters, the one place their defaults are written (node, ``imu-noise-id cmkf``, replay)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..constants import STANDARD_GRAVITY
from . import rotation as rot

MEASUREMENTS = ("twist", "pose_twist")
GRAVITY_SOURCES = ("odometry", "imu")
PD_CHECKS = ("se_floor", "per_axis", "joint")


@dataclass
class CmkfConfig:
    """Parameters of :class:`~.robot.RobotCmkf` (SI units; what each one does: docs/cmkf.md).

    Attributes
    ----------
    imu_rotation_xyzw : orientation of the IMU frame in the base frame (``C_bi``), ROS quaternion order.
    accel_bias_tau, accel_bias_sigma, s_v0 : bias time constant [s], steady-state σ [m/s²] (eqs. 3–7), initial Ŝ_v
        [m²/s³]; gyro_bias_tau, gyro_bias_sigma, s_g0 : the same for the gyro [s], [rad/s], [rad²/s].
    velocity_noise_std, position_noise_std, angular_velocity_noise_std : odometry noise [m/s], [m], [rad/s]; None:
        the message covariance, ``default_*`` when missing or all zeros (REP-145).
    late_odom_tolerance : stamp merger latency [s]; min_odom_interval : odometry closer to the last update dropped [s].
    pd_check : Ŝ_v, Ŝ_g in use (:meth:`~.matching.MatchingLeastSquares.working`, or the last positive per axis or
        jointly); min_samples : stacked samples before Ŝ_v is used; nis_gate_probability : χ² tail of :mod:`.gate`.
    """

    imu_rotation_xyzw: tuple[float, float, float, float] = rot.IDENTITY
    measurement: str = "twist"
    accel_bias_tau: float = 3600.0
    accel_bias_sigma: float = 0.1
    s_v0: float = 1e-4
    gyro_bias_tau: float = 3600.0
    gyro_bias_sigma: float = 0.01
    s_g0: float = 1e-6
    velocity_noise_std: float | None = None
    position_noise_std: float | None = None
    angular_velocity_noise_std: float | None = None
    default_velocity_noise_std: float = 0.05
    default_position_noise_std: float = 0.05
    default_angular_velocity_noise_std: float = 0.05
    gravity: float = STANDARD_GRAVITY
    gravity_source: str = "odometry"
    max_odom_gap: float = 1.0
    max_imu_gap: float = 0.5
    late_odom_tolerance: float = 0.05
    min_odom_interval: float = 1e-4
    pd_check: str = "se_floor"
    min_samples: int = 10
    nis_window: int = 50
    nis_gate_probability: float = 1e-6

    def validate(self) -> None:
        """Raise ValueError naming the first absurd parameter."""
        if self.measurement not in MEASUREMENTS:
            raise ValueError(f"measurement must be one of {MEASUREMENTS}, got {self.measurement!r}")
        if self.gravity_source not in GRAVITY_SOURCES:
            raise ValueError(f"gravity_source must be one of {GRAVITY_SOURCES}, got {self.gravity_source!r}")
        rot.normalise(self.imu_rotation_xyzw)
        for name in ("accel_bias_tau", "accel_bias_sigma", "s_v0", "gyro_bias_tau", "gyro_bias_sigma", "s_g0",
                     "default_velocity_noise_std", "default_position_noise_std",
                     "default_angular_velocity_noise_std", "max_odom_gap", "max_imu_gap"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        for name in ("velocity_noise_std", "position_noise_std", "angular_velocity_noise_std"):
            value = getattr(self, name)
            if value is not None and not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be None or a finite number > 0, got {value!r}")
        for name in ("late_odom_tolerance", "min_odom_interval"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
        if not (math.isfinite(self.nis_gate_probability) and 0.0 <= self.nis_gate_probability < 0.5):
            raise ValueError(f"nis_gate_probability must be in [0, 0.5), got {self.nis_gate_probability!r}")
        if self.pd_check not in PD_CHECKS:
            raise ValueError(f"pd_check must be one of {PD_CHECKS}, got {self.pd_check!r}")
        for name in ("min_samples", "nis_window"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
