"""Whiteness and consistency of the online filters' standardised innovations: one ``InnovationMonitor`` per CMKF
axis and component and per gyro axis; the ``Filter innovations`` status names the failing channel."""

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
    """Innovation monitors of the CMKF and the gyro-bias filter: ``window``, ``lags``, ``alpha`` of each monitor
    (``innovations.*``), ``components`` per CMKF axis (1 or 2); InputError unless ``lags`` < ``window / 4``."""

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
