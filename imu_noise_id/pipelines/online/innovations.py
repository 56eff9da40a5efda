"""Are the online filters' innovations white and consistent? One InnovationMonitor per measurement channel.

After every odometry update the CMKF's innovations (per IMU axis: velocity, and position with ``pose_twist``) and
the gyro-bias filter's (per axis) are standardised by their predicted variances and kept in a
:class:`~imu_noise_id.core.diagnostics.monitor.InnovationMonitor` (windowed Ljung–Box and NIS tests, the offline
loop's statistics). Correlated innovations mean the filter's model misses something (vibration, a lever arm, wheel
slip, coloured odometry noise); inconsistent ones that its noise figures are wrong. The ``Filter innovations``
status says which channel fails and how, e.g. "model inadequate: accel_y: residuals correlated at lag 1 …".
"""

from __future__ import annotations

import math

import numpy as np

from ...core.axes import ACCEL_AXES, GYRO_AXES
from ...core.cmkf.robot import RobotCmkf
from ...core.diagnostics.monitor import InnovationMonitor
from ...core.errors import InputError
from .status import OK, WARN, DiagnosticStatus

NAME = "Filter innovations"


class InnovationChecks:
    """Innovation monitors of the CMKF (per IMU axis and measurement component) and of the gyro-bias filter.

    Parameters
    ----------
    window, lags, alpha : of each :class:`InnovationMonitor` (``innovations.*`` parameters).
    components : measurement components per axis of the CMKF (1: velocity; 2: position and velocity).

    Raises
    ------
    InputError
        If the monitor parameters are inconsistent (``lags`` not below ``window / 4``).
    """

    def __init__(self, window: int, lags: int, alpha: float, components: int) -> None:
        names = ("velocity",) if components == 1 else ("position", "velocity")
        self.accel = [[f"{axis}" if components == 1 else f"{axis} {name}" for name in names] for axis in ACCEL_AXES]
        try:
            self._monitors = {name: InnovationMonitor(window, lags, alpha)
                              for name in [*(c for row in self.accel for c in row), *GYRO_AXES]}
        except ValueError as exc:
            raise InputError(f"parameters innovations.*: {exc}") from None
        self.window = window

    def add(self, cmkf: RobotCmkf) -> None:
        """The innovations of the update ``cmkf`` just made (none when the message did not update it)."""
        accel, gyro = cmkf.last_update
        if accel:
            y, S = np.asarray(cmkf.filter.y), np.asarray(cmkf.filter.S)
            for i, row in enumerate(self.accel):
                for j, name in enumerate(row):
                    self._add(name, float(y[i, j]), float(S[i, j, j]))
        if gyro:
            for name, nu, s in zip(GYRO_AXES, cmkf.gyro.y, cmkf.gyro.S, strict=True):
                self._add(name, float(nu), float(s))

    def _add(self, name: str, nu: float, s: float) -> None:
        if math.isfinite(nu) and math.isfinite(s) and s > 0:
            self._monitors[name].update(nu, s)

    def status(self) -> DiagnosticStatus:
        """The verdict over the last ``window`` updates of each channel with a full window."""
        values = {}
        problems = []
        ready = 0
        for name, monitor in self._monitors.items():
            if not monitor.ready:
                continue
            ready += 1
            verdict = monitor.status()
            key = name.replace(" ", "_")
            values[f"{key}_ljung_box_p"] = f"{verdict.ljung_box_p:.3g}"
            values[f"{key}_nis_mean"] = f"{verdict.nis_mean:.3f}"
            if not verdict.ok:
                problems.append(f"{name}: {verdict.message.removeprefix('model inadequate: ')}")
        values["channels_tested"] = f"{ready}/{len(self._monitors)}"
        if problems:
            return DiagnosticStatus(NAME, WARN, "model inadequate: " + "; ".join(problems), values)
        if not ready:
            return DiagnosticStatus(NAME, OK, f"collecting innovations (tests over {self.window} updates)", values)
        return DiagnosticStatus(NAME, OK, f"innovations white and consistent over the last {self.window} updates "
                                f"({ready} channels)", values)
