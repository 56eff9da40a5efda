"""Offline replay of the online CMKF (:class:`~imu_noise_id.core.cmkf.robot.RobotCmkf`) over recorded arrays.

The messages are fed one at a time in stamp order (IMU before odometry on equal stamps; the merge of
:func:`~imu_noise_id.core.cmkf.merge.stamp_order`, as in the node) by
:func:`~imu_noise_id.core.cmkf.stream.feed_recording`, as fast as the filter runs; the estimate is recorded after
every odometry message.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from ..core.axes import ImuSeries, OdometrySeries
from ..core.cmkf.config import CmkfConfig
from ..core.cmkf.robot import CmkfEstimate, RobotCmkf
from ..core.cmkf.stream import feed_recording
from ..core.diagnostics.consistency import nis_bounds
from ..core.errors import InputError
from ..core.timing import sampling_period

#: Per-axis fields of :class:`CmkfEstimate` recorded over time.
SERIES_FIELDS = (
    "accel_bias", "accel_bias_std", "S_v", "S_v_ls", "accel_noise_density",
    "gyro_bias", "gyro_bias_std", "S_g", "S_g_ls", "gyro_noise_density",
)


@dataclass
class CmkfReplayResult:
    """Estimates after every odometry message, the final estimate and what the filter knew.

    Attributes
    ----------
    t : (M,) odometry stamps [s]; series : field → (M, 3) arrays (see :data:`SERIES_FIELDS`, IMU axes);
    nis_accel, nis_gyro : (M,) NIS of each update (NaN when no update); status : (M,) status strings;
    final : the estimate after the last message; config : the filter's parameters; info : rates, frames, timing.
    """

    t: np.ndarray
    series: dict[str, np.ndarray]
    nis_accel: np.ndarray
    nis_gyro: np.ndarray
    status: list[str]
    final: CmkfEstimate
    config: CmkfConfig
    info: dict[str, object] = field(default_factory=dict)


def _rate(t: np.ndarray) -> float:
    """Rate [Hz] of a stream by the package's one sampling rule (nan for fewer than two usable stamps)."""
    try:
        return 1.0 / sampling_period(t)
    except InputError:
        return math.nan


def replay(
    imu: ImuSeries,
    odom: OdometrySeries | None,
    config: CmkfConfig | None = None,
    imu_orientation_xyzw: np.ndarray | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> CmkfReplayResult:
    """Run :class:`RobotCmkf` over ``imu`` and ``odom`` (None: IMU only, nothing observable).

    A field of ``odom`` (position, orientation, velocities, covariances) may be None when the source does not
    provide it (e.g. motion capture without angular velocity).

    ``imu_orientation_xyzw`` (N, 4), the IMU's own orientation, is used for gravity only with
    ``config.gravity_source == "imu"``; a NaN row (not provided, see :class:`~imu_noise_id.core.axes.ImuSeries`)
    is passed as None, so the filter keeps the last orientation it was given. ``progress(done, total)`` is called
    after every odometry message.
    """
    config = config or CmkfConfig()
    filt = RobotCmkf(config)
    ti = np.asarray(imu.t, dtype=float)
    to = np.asarray(odom.t, dtype=float) if odom is not None else np.zeros(0)
    rec = {name: [] for name in SERIES_FIELDS}
    nis_a, nis_g, status = [], [], []
    t_start = time.perf_counter()
    for k, updated in enumerate(feed_recording(filt, imu, odom, imu_orientation_xyzw), start=1):
        if progress is not None:
            progress(k, to.size)
        est = filt.estimate()
        for name in SERIES_FIELDS:
            rec[name].append(getattr(est, name))
        nis_a.append(est.nis_accel if updated else math.nan)
        nis_g.append(est.nis_gyro if updated else math.nan)
        status.append(est.status)
    elapsed = time.perf_counter() - t_start
    final = filt.estimate()
    info: dict[str, object] = {
        "imu_topic": imu.topic, "imu_frame": imu.frame_id, "imu_samples": int(ti.size), "imu_rate_hz": _rate(ti),
        "odom_topic": odom.topic if odom is not None else None,
        "odom_frame": odom.frame_id if odom is not None else None,
        "odom_child_frame": odom.child_frame_id if odom is not None else None,
        "odom_messages": int(to.size), "odom_rate_hz": _rate(to),
        "duration_s": float(max(ti[-1], to[-1] if to.size else ti[-1]) - min(ti[0], to[0] if to.size else ti[0])),
        "replay_seconds": elapsed, "imu_samples_per_second": ti.size / elapsed if elapsed > 0 else math.inf,
    }
    series = {name: np.array(v).reshape(-1, 3) for name, v in rec.items()}
    return CmkfReplayResult(to, series, np.array(nis_a), np.array(nis_g), status, final, config, info)


def nis_summary(nis: np.ndarray, dof: int, skip_fraction: float = 0.2) -> dict[str, float]:
    """Mean NIS and the share inside the χ²(dof) 95 % bounds, after dropping the first ``skip_fraction``."""
    x = nis[np.isfinite(nis)]
    x = x[int(skip_fraction * x.size):]
    if x.size == 0:
        return {"mean": math.nan, "dof": dof, "share_in_95": math.nan, "n": 0}
    lo, hi = nis_bounds(dof)
    return {"mean": float(x.mean()), "dof": dof, "share_in_95": float(np.mean((x >= lo) & (x <= hi))), "n": int(x.size)}


def to_yaml_dict(result: CmkfReplayResult, notes: list[str] | None = None) -> dict[str, object]:
    """The ``cmkf.yaml`` schema of ``architecture.md`` (per IMU axis x, y, z; SI units) plus what the filter knew."""
    e = result.final

    def xyz(a: np.ndarray) -> dict[str, float]:
        return {k: float(v) for k, v in zip("xyz", a, strict=True)}

    cfg = asdict(result.config)
    cfg["imu_rotation_xyzw"] = [float(v) for v in cfg["imu_rotation_xyzw"]]
    return {
        "frame": "IMU axes (sensor frame of the Imu messages)",
        "status": e.status,
        "observed": e.observed,
        "accel_bias": xyz(e.accel_bias),
        "accel_bias_std": xyz(e.accel_bias_std),
        "S_v": xyz(e.S_v),
        "S_v_least_squares": xyz(e.S_v_ls),
        "accel_noise_density": xyz(e.accel_noise_density),
        "gyro_bias": xyz(e.gyro_bias),
        "gyro_bias_std": xyz(e.gyro_bias_std),
        "S_g": xyz(e.S_g),
        "S_g_least_squares": xyz(e.S_g_ls),
        "gyro_noise_density": xyz(e.gyro_noise_density),
        "units": {
            "accel_bias": "m/s^2", "S_v": "m^2/s^3", "accel_noise_density": "m/s^2/sqrt(Hz)",
            "gyro_bias": "rad/s", "S_g": "rad^2/s", "gyro_noise_density": "rad/s/sqrt(Hz)",
        },
        "n_stacked": e.n_stacked,
        "nis": {
            "accel": nis_summary(result.nis_accel, e.nis_accel_dof),
            "gyro": nis_summary(result.nis_gyro, e.nis_gyro_dof),
        },
        "counters": e.counters,
        "filter": {**{k: v for k, v in result.info.items() if k != "replay_seconds"}, "parameters": cfg},
        "notes": list(notes or []),
    }
