"""The rest phases of the BROAD trials in ``../shared/data/broad_trials``: short records of a consumer module (myon
aktos-t, 285.7 Hz, 28–42 s at rest), whose gyros carry a 22 Hz harmonic family."""

from __future__ import annotations

from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "broad_trials"
#: The data's ``movement`` flag lags the motion's start by up to 1.3 s (``bench_motion_bursts.py``): a rest phase
#: ends this much [s] before it.
MOTION_MARGIN_S = 2.0


def load_rest(trial: int, samples: int = 0) -> tuple[np.ndarray, float]:
    """Trial ``trial``'s rest before its motion (the samples up to :data:`MOTION_MARGIN_S` before the data's first
    ``movement`` flag), shape (N, 6) in :data:`imu_noise_id.core.axes.AXES` order (gyro rad/s, then accel m/s²),
    its first ``samples`` only when non-zero, and the sample period dt [s] (the median stamp step)."""
    path, = DATA.glob(f"broad_{trial}_*.npz")
    d = np.load(path)
    dt = float(np.median(np.diff(d["t"])))
    rest = slice(0, int(np.argmax(d["movement"])) - round(MOTION_MARGIN_S / dt))
    data = np.hstack([d["gyro"][rest], d["accel"][rest]])
    return (data[:samples] if samples else data), dt
