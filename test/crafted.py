"""Crafted IMU recordings for the input tests: bursty host stamps, NaN messages, truncated files.

Helpers (not tests) shared by ``test_timing.py``, ``test_truncated_bags.py`` and ``test_bad_input_corpus.py``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from imu_noise_id.core.axes import ImuSeries
from imu_noise_id.core.noise.modelspec import parse_imu_model
from imu_noise_id.core.simulation.static import simulate_static_imu

#: The simulated sensor's white-noise densities [rad/s/√Hz, m/s²/√Hz] (the truth the tests compare with).
GYRO_N, ACCEL_N = 1e-3, 2e-3
MODEL = f"gyro: WN({GYRO_N})+RW(1e-5); accel: WN({ACCEL_N})+RW(4e-4)"


def static_imu(rate: float = 100.0, duration: float = 120.0, seed: int = 3, t0: float = 1.7e9) -> ImuSeries:
    """A simulated static IMU (:data:`MODEL`) whose stamps are its sample times."""
    return simulate_static_imu(parse_imu_model(MODEL), rate, duration, seed=seed, t0=t0)


def bursty_stamps(t: np.ndarray, read_every: float = 0.05, spacing: float = 0.002, seed: int = 1) -> np.ndarray:
    """Host stamps of samples taken at ``t``: a serial driver reads every ``read_every`` s (plus up to 4 ms of
    scheduling delay) and stamps the samples it finds ``spacing`` s apart, as an MPU-6050 behind a USB UART does."""
    rng = np.random.default_rng(seed)
    reads = np.arange(t[0], t[-1] + 2 * read_every, read_every)
    reads = reads + rng.uniform(0.0, 0.004, size=reads.size)
    read_time = reads[np.searchsorted(reads, t)]
    first = np.r_[True, read_time[1:] != read_time[:-1]]
    group = np.cumsum(first) - 1
    within = np.arange(t.size) - np.flatnonzero(first)[group]
    return read_time + spacing * within


def with_stamps(imu: ImuSeries, t: np.ndarray) -> ImuSeries:
    return ImuSeries(t=t, gyro=imu.gyro, accel=imu.accel, frame_id=imu.frame_id)


def cut_file(src: Path, dst: Path, fraction: float) -> Path:
    """Copy the first ``fraction`` of the bytes of ``src`` to ``dst`` (a recorder killed mid-write)."""
    data = src.read_bytes()
    dst.write_bytes(data[: int(len(data) * fraction)])
    return dst
