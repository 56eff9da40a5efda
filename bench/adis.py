"""The ADIS16405 static runs in ``../shared/data/adis16405_static``: the measured closed-loop benches' input."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "adis16405_static"


def load_run(run: int, samples: int = 0) -> tuple[np.ndarray, float]:
    """Run ``run``'s rates, shape (N, 6) in :data:`imu_noise_id.core.axes.AXES` order (gyro rad/s, then accel
    m/s²), its first ``samples`` only when non-zero, and the sample period dt [s]."""
    d = np.load(DATA / f"adis16405_run{run}.npz")
    data = np.hstack([d["gyro"], d["accel"]])
    return (data[:samples] if samples else data), 1.0 / float(d["fs_hz"])


def data_missing() -> bool:
    """Whether the runs are absent (said on stderr): the benches then exit with 2."""
    if DATA.is_dir():
        return False
    print(f"no data at {DATA}", file=sys.stderr)
    return True
