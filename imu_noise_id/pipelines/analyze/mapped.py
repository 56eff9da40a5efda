"""The recording's arrays in memory-mapped files, read by every worker process of one analysis without a copy each.

A worker process sent the recording itself receives a pickled copy of every array; mapped, the operating system's page
cache holds one copy that all processes read (clean file pages, which memory pressure may also drop and re-read).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ...core.axes import ImuSeries

#: The arrays of an :class:`~imu_noise_id.core.axes.ImuSeries` that scale with the record, and their empty shapes.
_ARRAYS = {"t": (0,), "gyro": (0, 3), "accel": (0, 3), "orientation_xyzw": (0, 4)}


@dataclass(frozen=True)
class MappedImu:
    """An :class:`~imu_noise_id.core.axes.ImuSeries` whose arrays are ``.npy`` files in ``folder``; ``series`` holds the
    rest (frame, topic, notes, sample period) with empty arrays. Pickles to a few hundred bytes whatever the record's
    length."""

    folder: Path
    series: ImuSeries

    @classmethod
    def write(cls, imu: ImuSeries, folder: Path) -> MappedImu:
        """Write the arrays of ``imu`` into ``folder`` (an existing, private directory) once."""
        empty = {}
        for name, shape in _ARRAYS.items():
            array = getattr(imu, name)
            if array is not None:
                np.save(folder / f"{name}.npy", np.ascontiguousarray(array))
                empty[name] = np.empty(shape)
        return cls(folder, replace(imu, **empty))

    def open(self) -> ImuSeries:
        """The recording, its arrays mapped read-only from the files (an in-place write raises ValueError)."""
        mapped = {name: np.load(self.folder / f"{name}.npy", mmap_mode="r")
                  for name in _ARRAYS if getattr(self.series, name) is not None}
        return replace(self.series, **mapped)
