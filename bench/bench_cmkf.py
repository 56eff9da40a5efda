"""Throughput of the offline CMKF replay and per-call latency of the streaming API (what the ROS node pays).

    PYTHONPATH=. nice -n 10 python bench/bench_cmkf.py > docs/results/bench_cmkf.txt

Cases: the Husky npz (IMU 30 Hz, odometry 10 Hz: one odometry update per 3 IMU samples), a simulated robot with
IMU 100 Hz / odometry 10 Hz (twist and pose_twist) and IMU 400 Hz / odometry 20 Hz, and IMU only (odometry
stops after 1 s: propagation without updates). The machine is shared: the load average is printed with the
numbers.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

from imu_noise_id.core.axes import ImuSeries, OdometrySeries
from imu_noise_id.core.cmkf import rotation as rot
from imu_noise_id.core.cmkf.config import CmkfConfig
from imu_noise_id.core.cmkf.merge import stamp_order
from imu_noise_id.core.cmkf.robot import RobotCmkf
from imu_noise_id.core.simulation.robot import simulate_robot
from imu_noise_id.pipelines.cmkf_replay import replay

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def sim_series(duration: float, imu_rate: float, odom_rate: float) -> tuple[ImuSeries, OdometrySeries, tuple]:
    run = simulate_robot(duration, np.random.default_rng(0), imu_rate=imu_rate, odom_rate=odom_rate)
    imu = ImuSeries(run.imu_t, run.gyro, run.accel)
    odom = OdometrySeries(run.odom_t, run.position, run.orientation_xyzw, run.linear_velocity,
                          run.angular_velocity, run.pose_cov, run.twist_cov)
    return imu, odom, run.imu_rotation_xyzw


def throughput(label: str, imu: ImuSeries, odom: OdometrySeries | None, cfg: CmkfConfig, repeat: int = 3) -> None:
    best = cpu_best = 0.0
    for _ in range(repeat):
        c0 = time.process_time()
        res = replay(imu, odom, cfg)
        cpu = time.process_time() - c0
        best = max(best, res.info["imu_samples_per_second"])
        cpu_best = max(cpu_best, len(imu) / cpu if cpu > 0 else np.inf)
    n_odom = 0 if odom is None else len(odom)
    print(f"{label:48s} {len(imu):>6d} IMU {n_odom:>5d} odom: {best:>8.0f} IMU samples/s wall, "
          f"{cpu_best:>8.0f} per CPU-second (best of {repeat})")


def latency(imu: ImuSeries, odom: OdometrySeries, cfg: CmkfConfig) -> None:
    f = RobotCmkf(cfg)
    ti, to, te = [], [], []
    imu_rows = [(float(t), tuple(g), tuple(a)) for t, g, a in zip(imu.t, imu.gyro, imu.accel, strict=True)]
    clock = time.perf_counter
    for is_odometry, k in stamp_order(imu.t, odom.t):
        a = clock()
        if not is_odometry:
            f.process_imu(*imu_rows[k])
            ti.append(clock() - a)
            continue
        f.process_odometry(odom.t[k], orientation_xyzw=odom.orientation_xyzw[k],
                           linear_velocity=odom.linear_velocity[k], angular_velocity=odom.angular_velocity[k],
                           twist_cov=odom.twist_covariance[k])
        b = clock()
        f.estimate()
        to.append(b - a)
        te.append(clock() - b)
    for name, x in (("process_imu", ti), ("process_odometry", to), ("estimate", te)):
        us = np.array(x) * 1e6
        print(f"  {name:18s} median {np.median(us):7.1f} us   p99 {np.percentile(us, 99):7.1f} us   "
              f"max {us.max():8.1f} us   ({us.size} calls)")


def main() -> None:
    print(f"load average at start: {os.getloadavg()[0]:.2f} (2 cores shared by several developers; 'wall' includes")
    print("waiting for a core, 'per CPU-second' is the filter's own cost). The replay records estimate() after")
    print("every odometry message.")
    husky = DATA / "husky_robot_localization" / "husky_test1.npz"
    if husky.exists():
        d = np.load(husky)
        m = d["odom_t"].size
        cov = np.zeros((m, 6, 6))
        cov[:, range(6), range(6)] = 1e-3
        imu = ImuSeries(d["imu_t"], d["imu_gyro"], d["imu_accel"])
        odom = OdometrySeries(d["odom_t"], d["odom_pos"], d["odom_quat_xyzw"], d["odom_twist_linear"],
                              d["odom_twist_angular"], cov, cov)
        cfg = CmkfConfig(imu_rotation_xyzw=rot.from_ypr(-np.pi / 2, 0.0, np.pi / 2))
        throughput("Husky npz (IMU 30 Hz / odometry 10 Hz)", imu, odom, cfg)
    else:
        print(f"(Husky data not found at {husky}: skipped)")
    for imu_rate, odom_rate in ((100.0, 10.0), (400.0, 20.0)):
        imu, odom, q = sim_series(120.0, imu_rate, odom_rate)
        cfg = CmkfConfig(imu_rotation_xyzw=q)
        throughput(f"simulated robot (IMU {imu_rate:g} Hz / odometry {odom_rate:g} Hz)", imu, odom, cfg)
        if imu_rate == 100.0:
            throughput("same, pose_twist measurement", imu, odom, CmkfConfig(imu_rotation_xyzw=q,
                                                                                   measurement="pose_twist"))
            first_second = OdometrySeries(*(np.asarray(a)[odom.t <= 1.0] for a in (
                odom.t, odom.position, odom.orientation_xyzw, odom.linear_velocity, odom.angular_velocity,
                odom.pose_covariance, odom.twist_covariance)))
            throughput("same, odometry only in the first 1 s (IMU only)", imu, first_second, cfg)
            print("per-call latency, simulated robot IMU 100 Hz / odometry 10 Hz (twist):")
            latency(imu, odom, cfg)
    print(f"load average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
