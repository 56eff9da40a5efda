"""What the robot CMKF reports (:class:`CmkfEstimate`) and the consistency verdict of its NIS windows."""

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
    """What :meth:`~.robot.RobotCmkf.estimate` returns (IMU frame, SI units; docs/cmkf.md, "Streaming API").

    Attributes
    ----------
    t : last processed stamp [s]; status : :func:`running_status`, or ``no_data``, ``no_imu``, ``imu_only``,
        ``unobserved``; observed : an odometry update within ``max_odom_gap`` and the IMU alive.
    accel_bias, accel_bias_std : [m/s²]; S_v : the working Ŝ_v [m²/s³]; S_v_ls, accel_ls : least squares (may be
        ≤ 0) and (S_v_ls, se, dof); gyro_bias, gyro_bias_std, S_g, S_g_ls, gyro_ls : the gyro's [rad/s], [rad²/s].
    nis_accel, nis_accel_dof, nis_accel_mean, nis_gyro, nis_gyro_dof, nis_gyro_mean : last NIS (also when gated), dof,
        mean of the window; gated : (accelerometer, gyro) gated; consistency, consistency_reason : :func:`consistency`.
    n_stacked : stacked samples in Ŝ_v; counters : messages used, dropped and gated, by reason.
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


def judge(windows: Sequence[NisWindow]) -> tuple[str, int]:
    """The most severe verdict of the (accelerometer, gyro) windows and its filter's index; among equal verdicts the
    mean NIS furthest from its dof (by ratio). The node's windows and the replay's whole run."""
    verdicts = [w.verdict() for w in windows]

    def severity(i: int) -> tuple[int, float]:
        ratio = windows[i].mean / windows[i].dof
        return (CONSISTENCY_ORDER.index(verdicts[i]),
                abs(math.log(ratio)) if math.isfinite(ratio) and ratio > 0 else math.inf)
    worst = max(range(len(windows)), key=severity)
    return verdicts[worst], worst


def consistency(windows: Sequence[NisWindow], checks: Sequence[AxisAgreement]) -> tuple[str, str]:
    """:func:`judge` of the (accelerometer, gyro) windows and, unless consistent, the reason with the likely cause."""
    verdict, worst = judge(windows)
    if verdict not in ("marginal", "inconsistent"):
        return verdict, ""
    parts = []
    for name, w in zip(("accelerometer", "gyro"), windows, strict=True):
        parts.append(f"{name} NIS mean {w.mean:.3g} for {w.dof} dof over {w.n} updates"
                     + (f", {100 * w.gated_share:.0f} % gated" if w.gated_share else ""))
    window = windows[worst]
    return verdict, "; ".join(parts) + ". Likely cause: " + likely_cause(window.mean / window.dof, checks)


#: The statuses of an observed filter (:func:`running_status`).
RUNNING = ("converging", "tracking", "inconsistent")


def running_status(n_stacked: int, min_samples: int, verdict: str) -> str:
    """Status of an observed filter with ``n_stacked`` stacked samples and consistency ``verdict``: ``inconsistent``,
    ``converging`` (fewer than ``min_samples``) or ``tracking``."""
    if verdict == "inconsistent":
        return "inconsistent"
    return "converging" if n_stacked < min_samples else "tracking"
