"""Per-axis agreement of the IMU and odometry changes, and the likely cause of an inconsistent CMKF it tells
(:func:`likely_cause`; beyond paper 004, docs/cmkf.md "Consistency")."""

from __future__ import annotations

import math
from collections.abc import Sequence

#: Slope below which an excited axis has the opposite sign, and the band around 1 inside which it agrees.
OPPOSITE_SLOPE = -0.5
AGREE_BAND = (0.5, 1.5)
#: Excitation: mean squared IMU change at least this many times the odometry's noise variance of the change.
EXCITATION = 9.0
#: Intervals needed before a verdict on an axis.
MIN_INTERVALS = 20


class AxisAgreement:
    """Per-axis slope of the odometry's change on the IMU's (``what``: ``"velocity"`` or ``"rotation"``)."""

    def __init__(self, what: str, axes: Sequence[str] = ("x", "y", "z")) -> None:
        self.what = what
        self.axes = tuple(axes)
        n = len(self.axes)
        self.count = 0
        self._xx = [0.0] * n
        self._xy = [0.0] * n
        self._noise = [0.0] * n

    def add(self, imu_change: Sequence[float], odom_change: Sequence[float], odom_variance: Sequence[float]) -> None:
        """One interval: the change integrated from the IMU, the odometry's, and the variance of the latter."""
        for i in range(len(self.axes)):
            x = imu_change[i]
            self._xx[i] += x * x
            self._xy[i] += x * odom_change[i]
            self._noise[i] += odom_variance[i]
        self.count += 1

    def slopes(self) -> list[float]:
        """Slope per axis (NaN where the IMU change is zero)."""
        return [xy / xx if xx > 0 else math.nan for xx, xy in zip(self._xx, self._xy, strict=True)]

    def excited(self) -> list[bool]:
        """Per axis: enough intervals, and the IMU's changes well above the odometry's noise."""
        return [self.count >= MIN_INTERVALS and xx > EXCITATION * noise
                for xx, noise in zip(self._xx, self._noise, strict=True)]

    def problems(self) -> list[str]:
        """One phrase per excited axis whose odometry change does not follow the IMU's."""
        out = []
        for axis, slope, excited in zip(self.axes, self.slopes(), self.excited(), strict=True):
            if not excited:
                continue
            if slope < OPPOSITE_SLOPE:
                out.append(f"the odometry's {self.what} on IMU axis {axis} has the opposite sign of the IMU's "
                           f"(slope {slope:.2f})")
            elif not AGREE_BAND[0] <= slope <= AGREE_BAND[1]:
                out.append(f"the odometry's {self.what} on IMU axis {axis} does not follow the IMU's "
                           f"(slope {slope:.2f}, 1 expected)")
        return out


def likely_cause(nis_ratio: float, checks: Sequence[AxisAgreement]) -> str:
    """The likely cause of an inconsistent filter whose mean NIS is ``nis_ratio`` × its degrees of freedom."""
    problems = [p for check in checks for p in check.problems()]
    if problems:
        return ("; ".join(problems) + ": likely a mirrored (left-handed) odometry frame or a wrong IMU mounting "
                "rotation (cmkf.imu_rotation_xyzw / --imu-rotation)")
    if not math.isfinite(nis_ratio):
        return "unknown"
    if nis_ratio > 1.0:
        return (f"the innovations are {nis_ratio:.3g}× larger than the filter predicts while IMU and odometry agree "
                "in sign and scale: the odometry covariance declared (or --velocity-noise-std) is likely too small, "
                "or the odometry has slip or vibration the model does not know")
    return (f"the innovations are {nis_ratio:.3g}× smaller than the filter predicts: the odometry covariance declared "
            "(or --velocity-noise-std) is likely too large, or the filter runs on the upper ends of S_v / S_g "
            "intervals the data cannot narrow (see the noise verdicts)")
