"""What the robot CMKF reports (:class:`CmkfEstimate`) and how its consistency verdict is formed."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .agreement import AxisAgreement, likely_cause
from .gate import NisWindow
from .psd import PsdEstimate, psd_estimate

#: Consistency verdicts, least to most severe (``unknown``: too few updates).
CONSISTENCY_ORDER = ("unknown", "consistent", "marginal", "inconsistent")


@dataclass
class CmkfEstimate:
    """What :meth:`~.robot.RobotCmkf.estimate` returns (IMU frame, SI units).

    Attributes
    ----------
    t : time of the estimate [s] (last processed stamp).
    status : ``no_data``, ``no_imu``, ``imu_only``, ``unobserved`` (no odometry update within ``max_odom_gap``, or no
        IMU within ``max_imu_gap``), ``converging`` (< ``min_samples``), ``tracking`` or ``inconsistent``.
    observed : an odometry update within ``max_odom_gap`` and the IMU alive.
    accel_bias, accel_bias_std : [m/s²] per axis (0 ± σ_ss before the first update).
    S_v : the working Ŝ_v [m²/s³] (not an estimate); S_v_ls : least squares (may be ≤ 0); accel_ls : (S_v_ls, se, dof).
    gyro_bias, gyro_bias_std, S_g, S_g_ls, gyro_ls : the same for the gyro [rad/s], [rad²/s].
    nis_accel, nis_accel_dof, nis_accel_mean : last NIS (also when gated), its dof, mean over the accepted ones of the
        last ``nis_window``; nis_gyro, nis_gyro_dof, nis_gyro_mean : the gyro's; gated : (accelerometer, gyro) gated.
    consistency, consistency_reason : the worse verdict of the two NIS windows (:data:`CONSISTENCY_ORDER`) and why.
    n_stacked : stacked samples in the S_v estimate; counters : messages used, dropped and gated, by reason.
    """

    t: float
    status: str
    observed: bool
    accel_bias: np.ndarray
    accel_bias_std: np.ndarray
    S_v: np.ndarray
    S_v_ls: np.ndarray
    accel_ls: tuple[np.ndarray, np.ndarray, int]
    gyro_bias: np.ndarray
    gyro_bias_std: np.ndarray
    S_g: np.ndarray
    S_g_ls: np.ndarray
    gyro_ls: tuple[np.ndarray, np.ndarray, int]
    nis_accel: float
    nis_accel_dof: int
    nis_accel_mean: float
    nis_gyro: float
    nis_gyro_dof: int
    nis_gyro_mean: float
    gated: tuple[bool, bool]
    consistency: str
    consistency_reason: str
    n_stacked: int
    counters: dict[str, int] = field(default_factory=dict)

    @cached_property
    def accel_psd(self) -> PsdEstimate:
        """S_v per axis with its interval and verdict."""
        return psd_estimate(*self.accel_ls)

    @cached_property
    def gyro_psd(self) -> PsdEstimate:
        """S_g per axis with its interval and verdict."""
        return psd_estimate(*self.gyro_ls)

    @property
    def accel_noise_density(self) -> np.ndarray:
        """√S_v where identified, NaN elsewhere [m/s²/√Hz]."""
        return self.accel_psd.density()

    @property
    def gyro_noise_density(self) -> np.ndarray:
        """√S_g where identified, NaN elsewhere [rad/s/√Hz]."""
        return self.gyro_psd.density()


def worst_filter(verdicts: Sequence[str], means: Sequence[float], dofs: Sequence[int]) -> int:
    """The filter with the most severe verdict; among equals, the mean NIS furthest from its dof (by ratio)."""
    def severity(i: int) -> tuple[int, float]:
        ratio = means[i] / dofs[i]
        return (CONSISTENCY_ORDER.index(verdicts[i]),
                abs(math.log(ratio)) if math.isfinite(ratio) and ratio > 0 else math.inf)
    return max(range(len(verdicts)), key=severity)


def consistency(windows: Sequence[NisWindow], checks: Sequence[AxisAgreement]) -> tuple[str, str]:
    """The worse verdict of the (accelerometer, gyro) NIS windows and, unless consistent, the reason."""
    verdicts = [w.verdict() for w in windows]
    worst = worst_filter(verdicts, [w.mean for w in windows], [w.dof for w in windows])
    verdict = verdicts[worst]
    if verdict not in ("marginal", "inconsistent"):
        return verdict, ""
    parts = []
    for name, w in zip(("accelerometer", "gyro"), windows, strict=True):
        parts.append(f"{name} NIS mean {w.mean:.3g} for {w.dof} dof over {w.n} updates"
                     + (f", {100 * w.gated_share:.0f} % gated" if w.gated_share else ""))
    window = windows[worst]
    return verdict, "; ".join(parts) + ". Likely cause: " + likely_cause(window.mean / window.dof, checks)
