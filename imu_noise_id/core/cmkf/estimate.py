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
    status : ``no_data``, ``no_imu`` (odometry only: nothing to estimate), ``imu_only`` (no odometry yet),
        ``unobserved`` (no odometry update for longer than ``max_odom_gap``, or no IMU sample for longer than
        ``max_imu_gap`` while odometry continues), ``converging`` (fewer than ``min_samples`` stacked samples),
        ``tracking``, or ``inconsistent`` (converging or tracking, but :attr:`consistency` is ``inconsistent``:
        the biases are not to be trusted).
    observed : True when an odometry update happened within ``max_odom_gap`` and the IMU is alive.
    accel_bias, accel_bias_std : [m/s²] per IMU axis (the prior 0 ± σ_ss before the first update).
    S_v : Ŝ_v the filter uses [m²/s³] (:meth:`~.matching.MatchingLeastSquares.working`): a working value, not an
        estimate to report; S_v_ls : the least-squares value (may be ≤ 0); accel_ls : (S_v_ls, its standard
        error, degrees of freedom), from which :attr:`accel_psd` (the estimate with its interval and per-axis
        verdict, :mod:`.psd`) and :attr:`accel_noise_density` (√S_v where identified, NaN elsewhere [m/s²/√Hz])
        are computed when asked for.
    gyro_bias, gyro_bias_std : [rad/s]; S_g, S_g_ls, gyro_ls, gyro_psd, gyro_noise_density : the same for the
        gyro [rad²/s], [rad/s/√Hz].
    nis_accel, nis_accel_dof : NIS of the last accelerometer-filter update (sum over axes, also when gated) and
        its dof; nis_accel_mean : mean over the accepted updates among the last ``nis_window``; nis_gyro,
        nis_gyro_dof, nis_gyro_mean : the same for the gyro.
    gated : whether the last odometry message's (accelerometer, gyro) update was rejected by the innovation gate.
    consistency : the worse verdict of the two filters' NIS windows (:data:`CONSISTENCY_ORDER`);
        consistency_reason : for ``marginal`` and ``inconsistent``, the numbers and the likely cause.
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
    """The filter whose verdict is the most severe; among equals, the one whose mean NIS is furthest from its
    degrees of freedom (by ratio): the one the likely cause is about."""
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
