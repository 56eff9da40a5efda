"""Simulation of a static 6-axis IMU from per-axis component models (for the demo, tests and benchmarks)."""

from __future__ import annotations

import numpy as np

from ..axes import AXES, ImuSeries
from ..constants import STANDARD_GRAVITY
from ..noise.components import Component, simulate_sum


def simulate_static_imu(
    model: dict[str, list[Component]],
    rate_hz: float,
    duration_s: float,
    *,
    seed: int | None = None,
    bias: dict[str, float] | None = None,
    gravity: float = STANDARD_GRAVITY,
    t0: float = 0.0,
    frame_id: str = "imu_link",
) -> ImuSeries:
    """Static level IMU with errors of ``model`` (axis → components), accel z + ``gravity``, one generator;
    ValueError on a non-positive rate or duration, fewer than two samples or a missing axis."""
    if not (np.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"rate must be > 0 Hz, got {rate_hz!r}")
    if not (np.isfinite(duration_s) and duration_s > 0):
        raise ValueError(f"duration must be > 0 s, got {duration_s!r}")
    n = round(duration_s * rate_hz)
    if n < 2:
        raise ValueError(f"rate {rate_hz} Hz × duration {duration_s} s gives {n} sample(s); need at least 2")
    missing = [a for a in AXES if a not in model]
    if missing:
        raise ValueError(f"IMU model has no components for {', '.join(missing)}")
    dt = 1.0 / rate_hz
    rng = np.random.default_rng(seed)
    bias = bias or {}
    data = np.empty((n, 6))
    for i, axis in enumerate(AXES):
        data[:, i] = simulate_sum(model[axis], n, dt, rng) + bias.get(axis, 0.0)
    data[:, 5] += gravity
    t = t0 + dt * np.arange(n)
    return ImuSeries(t=t, gyro=data[:, :3], accel=data[:, 3:], frame_id=frame_id, topic="simulated")
