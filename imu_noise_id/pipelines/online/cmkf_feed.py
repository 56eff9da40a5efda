"""The online CMKF (paper 004 on a robot) behind a ``CmkfStream`` (IMU held ``cmkf.input_latency`` seconds for stamp
order; later odometry counted, unused), restarted on any error; innovations to ``InnovationChecks``."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ...core.cmkf.config import CmkfConfig
from ...core.cmkf.merge import TOO_LATE
from ...core.cmkf.robot import CmkfEstimate, RobotCmkf
from ...core.cmkf.stream import CmkfStream
from .config import OnlineConfig, cmkf_config
from .events import EventLog
from .innovations import InnovationChecks


class CmkfFeed:
    """The CMKF behind its stamp merger, its latest estimate, and the checks of its innovations.

    Parameters
    ----------
    config : ``cmkf.*`` and ``innovations.*`` (InputError if invalid); events : gated updates, errors go there.
    cmkf : the CMKF's parameters instead of ``config``'s ``cmkf.*`` and ``nis.window`` (the replay's: every field).
    on_odometry : ``on_odometry(t, updated)`` after every odometry message the merger released to the CMKF.

    Attributes: ``estimate``; ``gyro_bias``, ``accel_bias`` (3,) (0 before the first odometry update); ``errors``
    (restarts), ``too_late``; ``innovations``.
    """

    def __init__(self, config: OnlineConfig, events: EventLog, cmkf: CmkfConfig | None = None,
                 on_odometry: Callable[[float, bool], None] | None = None) -> None:
        self._config = cmkf or cmkf_config(config)
        self._innovation_parameters = (config.innovations_window, config.innovations_lags, config.innovations_alpha)
        self._events = events
        self._listener = on_odometry
        self.stream = CmkfStream(self._config, on_odometry=self._on_odometry)
        self.innovations = InnovationChecks(*self._innovation_parameters, self.cmkf.filter.m)
        self._estimate: CmkfEstimate | None = None
        self.gyro_bias = np.zeros(3)
        self.accel_bias = np.zeros(3)
        self.errors = 0
        self.too_late = 0

    @property
    def cmkf(self) -> RobotCmkf:
        """The filter."""
        return self.stream.cmkf

    def set_latency(self, latency: float) -> None:
        """``cmkf.input_latency`` changed at runtime."""
        self.stream.merger.latency = latency

    def imu(self, t: float, gyro: Any, accel: Any, orientation_xyzw: Any) -> bool:
        """One accepted IMU message; True when the estimate changed (an odometry update was processed now)."""
        return self._feed(self.stream.process_imu, t, gyro, accel, orientation_xyzw)

    def odometry(self, t: float, **fields: Any) -> bool:
        """One accepted odometry message (``RobotCmkf.process_odometry`` keywords); True when the estimate changed."""
        return self._feed(self.stream.process_odometry, t, **fields)

    def new_time_line(self) -> None:
        """The stamps of an input restarted: the filter forgets its times and keeps its estimates."""
        self._feed(self.stream.new_time_line)

    def flush(self) -> None:
        """The end of the input: every message the merger holds goes to the CMKF."""
        self._feed(self.stream.flush)

    @property
    def estimate(self) -> CmkfEstimate:
        """The CMKF's estimate after the last update or :meth:`refresh` (formed when asked for)."""
        if self._estimate is None:
            self._estimate = self.stream.estimate()
        return self._estimate

    def refresh(self) -> None:
        """Re-read the estimate (its status changes without odometry updates too)."""
        self._estimate = None

    def _feed(self, process: Any, *args: Any, **kwargs: Any) -> bool:
        try:
            updated = process(*args, **kwargs)
        except (np.linalg.LinAlgError, ArithmeticError, ValueError) as exc:
            self.errors += 1
            self._events.count("cmkf_error")
            self._events.event("cmkf_error", f"CMKF failed ({type(exc).__name__}: {exc}): restarting it")
            self.stream.restart()
            self.innovations = InnovationChecks(*self._innovation_parameters, self.cmkf.filter.m)
            updated = True
        if updated:
            self._estimate = None
            cmkf = self.cmkf
            if cmkf.filter.initialised:
                self.gyro_bias = cmkf.gyro.x
                self.accel_bias = np.array(cmkf.imu.b)
        return updated

    def _on_odometry(self, t: float, order: int, updated: bool) -> None:
        if order == TOO_LATE:  # the CMKF has propagated past it: not used
            self.too_late += 1
            self._events.count("odom_too_late")
            self._events.event("odom_too_late", f"odom: message at t = {t:.6f} s arrived more than "
                               "cmkf.input_latency after the IMU: not used by the CMKF")
        else:
            self.innovations.add(self.cmkf)
            cmkf = self.cmkf
            for gated, key, what, nis, gate in zip(cmkf.last_gated, ("cmkf_gated_accel", "cmkf_gated_gyro"),
                                                   ("accelerometer", "gyro"), cmkf.last_nis, cmkf.gates, strict=True):
                if gated:
                    self._events.count(key)
                    self._events.event(key, f"CMKF: {what} update at t = {t:.6f} s rejected by the innovation gate "
                                       f"(NIS {nis:.3g} > {gate.threshold:.3g}): a bump, a saturated or corrupted "
                                       "sample, wheel slip; the bias is kept")
        if self._listener is not None:
            self._listener(t, updated)
