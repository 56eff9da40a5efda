"""The rest phases of the BROAD trials in ``../shared/data/broad_trials``: short records of a consumer module (myon
aktos-t, 285.7 Hz, 28–42 s at rest), whose gyros carry a 22 Hz harmonic family."""

from __future__ import annotations

from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "broad_trials"


def load_rest(trial: int, samples: int = 0) -> tuple[np.ndarray, float]:
    """Trial ``trial``'s rest before its motion (the samples before the data's first ``movement`` flag), shape
    (N, 6) in :data:`imu_noise_id.core.axes.AXES` order (gyro rad/s, then accel m/s²), its first ``samples`` only
    when non-zero, and the sample period dt [s] (the median stamp step)."""
    path, = DATA.glob(f"broad_{trial}_*.npz")
    d = np.load(path)
    rest = slice(0, int(np.argmax(d["movement"])))
    data = np.hstack([d["gyro"][rest], d["accel"][rest]])
    return (data[:samples] if samples else data), float(np.median(np.diff(d["t"][rest])))
