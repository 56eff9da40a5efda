"""Stamp-ordered merge of the IMU and odometry streams (IMU first on equal stamps: the sample that ends an interval
belongs to it). Recordings: :func:`stamp_order`. Live: :class:`StampMerger` holds messages until the newest IMU
stamp is ``latency`` seconds past them; odometry later than that is :data:`TOO_LATE`."""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterator
from typing import Generic, TypeVar

import numpy as np

Item = TypeVar("Item")

#: How an odometry message reached its place in the merged stream.
IN_ORDER, LATE, TOO_LATE = 0, 1, 2
#: [s] newest odometry this far from the newest IMU stamp: IMU silent, odometry moves the merge.
IMU_SILENT = 1.0


class StampMerger(Generic[Item]):
    """IMU and odometry in arrival order (each in stamp order), out in stamp order ``latency`` [s] behind the newest IMU
    stamp as ``(t, is_odometry, item, order)``, ``order`` :data:`IN_ORDER`, :data:`LATE` or :data:`TOO_LATE`."""

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
    """Whole recordings: ``(is_odometry, index)`` of every message in stamp order, IMU first on equal stamps."""
    merger: StampMerger[int] = StampMerger()
    for j, t in enumerate(np.asarray(odom_t, dtype=float).tolist()):
        merger.push_odometry(t, j)
    for i, t in enumerate(np.asarray(imu_t, dtype=float).tolist()):
        merger.push_imu(t, i)
        for _, is_odometry, k, _ in merger.until(t):
            yield is_odometry, k
    for _, is_odometry, k, _ in merger.flush():
        yield is_odometry, k
