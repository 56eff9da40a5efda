"""Crafted IMU recordings for the input tests: bursty host stamps, NaN messages, truncated files.

Helpers (not tests) shared by ``test_timing.py``, ``test_truncated_bags.py``, ``test_bad_input_corpus.py``,
``test_bag_quality.py`` and ``test_analyze.py``.
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


def touched(imu: ImuSeries, start_s: float, length_s: float, gyro: float, accel: float) -> ImuSeries:
    """``imu`` with a hand's touch from ``start_s`` for ``length_s`` [s] after its first sample: a decaying 8 Hz shake
    of amplitudes ``gyro`` [rad/s] on gyro_x, y and ``accel`` [m/s²] on accel_z (a moment of motion)."""
    u = imu.t - imu.t[0] - start_s
    shake = np.where((u >= 0) & (u < length_s), np.exp(-u / length_s) * np.sin(2 * np.pi * 8.0 * u), 0.0)
    gyro_out, accel_out = imu.gyro.copy(), imu.accel.copy()
    gyro_out[:, :2] += gyro * shake[:, None]
    accel_out[:, 2] += accel * shake
    return ImuSeries(t=imu.t, gyro=gyro_out, accel=accel_out, topic=imu.topic)


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


def write_ros1_bag(path: Path, imu: ImuSeries, topic: str = "/imu/data", compression: str | None = None,
                   chunk_bytes: int = 64 * 1024) -> Path:
    """A ROS 1 bag of ``imu`` (rosbags' ROS 1 writer; small chunks so that a cut falls between several)."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    imu_type = store.types["sensor_msgs/msg/Imu"]
    header_type, time_type = store.types["std_msgs/msg/Header"], store.types["builtin_interfaces/msg/Time"]
    vector, quaternion = store.types["geometry_msgs/msg/Vector3"], store.types["geometry_msgs/msg/Quaternion"]
    writer = Writer(path)
    if compression:
        writer.set_compression(getattr(Writer.CompressionFormat, compression.upper()))
    writer.chunk_threshold = chunk_bytes
    with writer:
        conn = writer.add_connection(topic, imu_type.__msgtype__, typestore=store)
        cov = np.zeros(9)
        for i, t in enumerate(imu.t):
            sec = int(t)
            stamp = time_type(sec=sec, nanosec=round((t - sec) * 1e9) % 1_000_000_000)
            msg = imu_type(header=header_type(seq=i, stamp=stamp, frame_id="imu_link"),
                           orientation=quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
                           orientation_covariance=np.r_[-1.0, np.zeros(8)],
                           angular_velocity=vector(*imu.gyro[i]), angular_velocity_covariance=cov,
                           linear_acceleration=vector(*imu.accel[i]), linear_acceleration_covariance=cov)
            writer.write(conn, round(t * 1e9), store.serialize_ros1(msg, imu_type.__msgtype__))
    return path
