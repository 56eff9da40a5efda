"""The robot CMKF fed in stamp order: live messages through a :class:`~.merge.StampMerger` (:class:`CmkfStream`),
or whole recordings straight to the filter (:func:`feed_recording`, for the simulated runs)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from ..axes import ImuSeries, OdometrySeries
from .config import CmkfConfig
from .merge import LATE, TOO_LATE, StampMerger, stamp_order
from .robot import CmkfEstimate, RobotCmkf

#: Odometry fields of :meth:`RobotCmkf.process_odometry` and the :class:`OdometrySeries` attribute of each.
ODOMETRY_FIELDS = (("position", "position"), ("orientation_xyzw", "orientation_xyzw"),
                   ("linear_velocity", "linear_velocity"), ("angular_velocity", "angular_velocity"),
                   ("pose_cov", "pose_covariance"), ("twist_cov", "twist_covariance"))


class CmkfStream:
    """A :class:`RobotCmkf` (``cmkf``) behind a :class:`StampMerger` (``merger``, its ``latency`` =
    ``late_odom_tolerance`` [s], changeable): messages in arrival order, processed in stamp order.
    ``on_odometry(t, order, updated)`` after every released odometry message (``order`` from :mod:`.merge`;
    ``updated``: :meth:`RobotCmkf.process_odometry`'s result, False for :data:`~.merge.TOO_LATE`)."""

    def __init__(self, config: CmkfConfig | None = None,
                 on_odometry: Callable[[float, int, bool], None] | None = None) -> None:
        self.cmkf = RobotCmkf(config)
        self.merger: StampMerger[Any] = StampMerger(self.cmkf.config.late_odom_tolerance)
        self._on_odometry = on_odometry

    def process_imu(self, t: float, gyro: Any, accel: Any, orientation_xyzw: Any = None) -> bool:
        """Queue one IMU message (:meth:`RobotCmkf.process_imu`), process what is due; True if odometry updated."""
        self.merger.push_imu(float(t), (gyro, accel, orientation_xyzw))
        return self._process(self.merger.ready())

    def process_odometry(self, t: float, **fields: Any) -> bool:
        """Queue one odometry message (keywords of :meth:`RobotCmkf.process_odometry`) and process what is due."""
        self.merger.push_odometry(float(t), fields)
        return self._process(self.merger.ready())

    def flush(self) -> bool:
        """Process every queued message (the end of the input)."""
        return self._process(self.merger.flush())

    def new_time_line(self) -> bool:
        """The stamps restarted: the queue processed, the filter's times forgotten (:meth:`RobotCmkf.new_time_line`),
        a new merger; True if a queued odometry message updated the filter."""
        updated = self.flush()
        self.cmkf.new_time_line()
        self.merger = StampMerger(self.merger.latency)
        return updated

    def restart(self) -> None:
        """A fresh filter with the same parameters; the queued messages are kept."""
        self.cmkf = RobotCmkf(self.cmkf.config)

    def estimate(self) -> CmkfEstimate:
        """The filter's current estimates (of the messages processed so far)."""
        return self.cmkf.estimate()

    def _process(self, items: Iterator[tuple[float, bool, Any, int]]) -> bool:
        updated = False
        for t, is_odometry, item, order in items:
            if not is_odometry:
                self.cmkf.process_imu(t, *item)
                continue
            used = order != TOO_LATE and self.cmkf.process_odometry(t, late=order == LATE, **item)
            updated |= used
            if self._on_odometry is not None:
                self._on_odometry(t, order, used)
        return updated


def feed_recording(cmkf: RobotCmkf, imu: ImuSeries, odom: OdometrySeries | None,
                   imu_orientation_xyzw: np.ndarray | None = None) -> Iterator[bool]:
    """Feed recorded series to ``cmkf`` in stamp order, yielding per odometry message whether it updated (None fields
    allowed; ``imu_orientation_xyzw`` as :func:`orientation_rows`)."""
    ti = np.asarray(imu.t, dtype=float)
    times = ti.tolist()
    rows = np.column_stack([imu.gyro, imu.accel]).tolist()
    quats = orientation_rows(imu_orientation_xyzw)
    to = np.zeros(0) if odom is None else np.asarray(odom.t, dtype=float)
    fields = [] if odom is None else [(key, getattr(odom, name)) for key, name in ODOMETRY_FIELDS]
    for is_odometry, k in stamp_order(ti, to):
        if is_odometry:
            yield cmkf.process_odometry(to[k], **{key: None if arr is None else arr[k] for key, arr in fields})
        else:
            row = rows[k]
            cmkf.process_imu(times[k], row[0:3], row[3:6], None if quats is None else quats[k])


def orientation_rows(orientation_xyzw: np.ndarray | None) -> list[list[float] | None] | None:
    """Per IMU sample its orientation ``[x, y, z, w]`` from (N, 4) ``orientation_xyzw``; None where a row is not finite
    (the message provides none)."""
    if orientation_xyzw is None:
        return None
    q = np.asarray(orientation_xyzw, dtype=float)
    return [row if ok else None for row, ok in zip(q.tolist(), np.isfinite(q).all(axis=1).tolist(), strict=True)]
