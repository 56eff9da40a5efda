"""Stamp-ordered merge of the IMU and odometry streams: the one place the CMKF's input order is made.

The robot CMKF (:class:`~.robot.RobotCmkf`) propagates with every IMU sample and updates at every odometry
message, so it needs the two streams merged in header-stamp order (IMU first on equal stamps: the sample that
ends an interval belongs to it). Recorded streams are merged exactly (:func:`stamp_order`). Live streams come on
two topics with different latencies: :class:`StampMerger` holds the messages until the newest IMU stamp has moved
``latency`` seconds past them, so odometry up to that much later than the IMU samples (in header time) is still
put in stamp order; odometry later than that arrives behind IMU samples already released and cannot be ordered
(reported :data:`TOO_LATE`, not given to the filter by :class:`~.stream.CmkfStream`).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterator
from typing import Generic, TypeVar

import numpy as np

Item = TypeVar("Item")

#: How an odometry message reached its place in the merged stream.
IN_ORDER, LATE, TOO_LATE = 0, 1, 2
#: [s] when the newest odometry is this far from the newest IMU sample, the IMU counts as silent and the
#: odometry's stamps move the merge on.
IMU_SILENT = 1.0


class StampMerger(Generic[Item]):
    """IMU and odometry messages in, in arrival order; out in stamp order, ``latency`` seconds behind the IMU.

    Every released message is a tuple ``(t, is_odometry, item, order)``: ``order`` is :data:`IN_ORDER`,
    :data:`LATE` (an odometry message that arrived after IMU samples stamped later than it and was put back in
    stamp order) or :data:`TOO_LATE` (an odometry message stamped before an IMU sample already released).
    Each stream must arrive in its own stamp order (messages are released first in, first out per stream).

    Parameters
    ----------
    latency : float
        How long [s, header time] messages wait behind the newest IMU stamp (0: released as soon as no earlier
        message can still come from the IMU).
    """

    def __init__(self, latency: float = 0.0) -> None:
        self.latency = float(latency)
        self.late = 0  # odometry messages put back in stamp order
        self.too_late = 0  # odometry messages released behind an IMU sample stamped later
        self._imu: deque[tuple[float, Item]] = deque()
        self._odom: deque[tuple[float, Item, bool]] = deque()
        self._newest_imu = math.nan
        self._released_imu = -math.inf
        self._horizon = -math.inf

    @property
    def pending(self) -> int:
        """Messages waiting."""
        return len(self._imu) + len(self._odom)

    def push_imu(self, t: float, item: Item) -> None:
        """An IMU message stamped ``t`` [s]; the merge may move on to ``t − latency``."""
        self._imu.append((t, item))
        self._newest_imu = t
        self._horizon = t - self.latency

    def push_odometry(self, t: float, item: Item) -> None:
        """An odometry message stamped ``t`` [s]; while the IMU is silent, its stamp moves the merge on."""
        self._odom.append((t, item, t < self._newest_imu))
        imu_alive = abs(t - self._newest_imu) < IMU_SILENT  # False while no IMU sample came (NaN)
        self._horizon = (self._newest_imu if imu_alive else t) - self.latency

    def ready(self) -> Iterator[tuple[float, bool, Item, int]]:
        """The messages stamped at or before the merge horizon, in stamp order (see the class docstring)."""
        return self.until(self._horizon)

    def flush(self) -> Iterator[tuple[float, bool, Item, int]]:
        """Every waiting message, in stamp order (the end of the input)."""
        return self.until(math.inf)

    def until(self, horizon: float) -> Iterator[tuple[float, bool, Item, int]]:
        """The messages stamped at or before ``horizon`` [s], in stamp order, IMU first on equal stamps."""
        imu, odom = self._imu, self._odom
        while imu or odom:
            t_imu = imu[0][0] if imu else math.inf
            t_odom = odom[0][0] if odom else math.inf
            if t_imu <= t_odom:
                if t_imu > horizon:
                    return
                t, item = imu.popleft()
                self._released_imu = t
                yield t, False, item, IN_ORDER
            else:
                if t_odom > horizon:
                    return
                t, item, late = odom.popleft()
                if t < self._released_imu:
                    self.too_late += 1
                    yield t, True, item, TOO_LATE
                else:
                    self.late += late
                    yield t, True, item, LATE if late else IN_ORDER


def stamp_order(imu_t: np.ndarray, odom_t: np.ndarray) -> Iterator[tuple[bool, int]]:
    """Whole recordings: ``(is_odometry, index)`` of every message in stamp order, IMU first on equal stamps.

    Both streams are known in advance, so nothing arrives late: the odometry is queued first and each IMU sample
    releases what it follows.
    """
    merger: StampMerger[int] = StampMerger()
    for j, t in enumerate(np.asarray(odom_t, dtype=float).tolist()):
        merger.push_odometry(t, j)
    for i, t in enumerate(np.asarray(imu_t, dtype=float).tolist()):
        merger.push_imu(t, i)
        for _, is_odometry, k, _ in merger.until(t):
            yield is_odometry, k
    for _, is_odometry, k, _ in merger.flush():
        yield is_odometry, k
