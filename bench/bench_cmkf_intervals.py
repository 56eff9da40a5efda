"""Do the CMKF's S_v and S_g intervals cover the truth on simulated robots, identifiable or not? (issue 12)

    PYTHONPATH=. nice -n 10 python bench/bench_cmkf_intervals.py > docs/results/bench_cmkf_intervals.txt

Robots of ``core/simulation/robot.py`` (weaving, IMU rotated as on the Husky, 100 Hz, constant biases) with
odometry twist of several rates and noise levels, 300 s each, several seeds; the robot CMKF (twist measurement,
default parameters, the message covariance declaring the true odometry noise) replayed over each. Per scenario and
sensor, over seeds × 3 axes:

- the mean of the least-squares Ŝ / truth and its standard error (is the estimator biased?), the median of the
  value the filter *used* (``max(Ŝ, se)``) and of the value printed before issue 12 (the last positive
  least-squares value, else the prior), all / truth;
- the share of the two-sided 95 % intervals Ŝ ± t·se that cover the truth (target 95 %), of the axes
  ``identified`` (interval above 0) and, among the others, of the bounds reported (the intervals' upper ends)
  above the truth.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

import numpy as np

from imu_noise_id.core.axes import ImuSeries, OdometrySeries
from imu_noise_id.core.cmkf.config import CmkfConfig
from imu_noise_id.core.cmkf.robot import RobotCmkf
from imu_noise_id.core.cmkf.stream import feed_recording
from imu_noise_id.core.simulation.robot import RobotSensors, simulate_robot


@dataclass(frozen=True)
class Scenario:
    name: str
    odom_rate: float  # [Hz]
    velocity_noise: float  # [m/s]
    angular_noise: float  # [rad/s]
    S_v: float  # [m²/s³]
    S_g: float  # [rad²/s]


SCENARIOS = (
    Scenario("quiet odometry", 10.0, 0.002, 0.002, 1e-4, 1e-6),
    Scenario("demo-like", 20.0, 0.005, 0.005, 1e-4, 1e-6),
    Scenario("issue: 1 cm/s at 20 Hz", 20.0, 0.01, 0.01, 1e-4, 1e-6),
    Scenario("issue, quieter IMU", 20.0, 0.01, 0.01, 1e-5, 1e-7),
    Scenario("noisy odometry", 20.0, 0.05, 0.05, 1e-4, 1e-6),
)
SEEDS = 16
DURATION = 300.0


def run_one(sc: Scenario, seed: int) -> dict[str, np.ndarray]:
    sensors = RobotSensors(S_v=sc.S_v, S_g=sc.S_g, velocity_noise_std=sc.velocity_noise,
                           angular_velocity_noise_std=sc.angular_noise)
    run = simulate_robot(DURATION, np.random.default_rng(1000 + seed), sensors=sensors, odom_rate=sc.odom_rate)
    f = RobotCmkf(CmkfConfig(imu_rotation_xyzw=run.imu_rotation_xyzw))
    imu = ImuSeries(run.imu_t, run.gyro, run.accel)
    odom = OdometrySeries(run.odom_t, run.position, run.orientation_xyzw, run.linear_velocity,
                          run.angular_velocity, run.pose_cov, run.twist_cov)
    # the value printed before issue 12: the last positive least-squares value (the paper's fallback), else the prior
    printed = {"S_v": np.full(3, f.config.s_v0), "S_g": np.full(3, f.config.s_g0)}
    for _ in feed_recording(f, imu, odom):
        for sensor, ls in (("S_v", f.filter.S_ls), ("S_g", f.gyro.S_ls)):
            printed[sensor] = np.where(ls > 0, ls, printed[sensor])
    e = f.estimate()
    out = {}
    for sensor, psd, used, truth in (("S_v", e.accel_psd, e.S_v, sc.S_v), ("S_g", e.gyro_psd, e.S_g, sc.S_g)):
        out[sensor] = np.column_stack([
            psd.value / truth, psd.se / truth, used / truth, printed[sensor] / truth,
            (psd.ci95[:, 0] <= truth) & (truth <= psd.ci95[:, 1]),
            psd.identified,
            np.array([v == "not_identifiable" for v in psd.verdict]),
            psd.upper95 >= truth,
        ])
    out["gated"] = np.array([e.counters["gated_accel"], e.counters["gated_gyro"], e.counters["updates"]])
    out["dof"] = np.array([e.accel_psd.dof, e.gyro_psd.dof])
    return out


def main() -> None:
    start = time.perf_counter()
    print(f"{SEEDS} seeds x {DURATION:.0f} s per scenario, IMU 100 Hz; per sensor over seeds x 3 axes")
    print(f"{'scenario':24} {'sensor':6} {'mean LS/truth':>16} {'rms se/truth':>12} {'used/truth':>10} "
          f"{'old/truth':>9} {'95% CI cover':>12} {'identified':>10} {'bound>=truth':>13} {'gated':>6} {'dof':>4}")
    for sc in SCENARIOS:
        runs = [run_one(sc, seed) for seed in range(SEEDS)]
        for j, sensor in enumerate(("S_v", "S_g")):
            rows = np.vstack([r[sensor] for r in runs])
            ratio = rows[:, 0]
            covered, identified, unident, upper_ok = (rows[:, k].astype(bool) for k in (4, 5, 6, 7))
            upper = f"{upper_ok[unident].mean():.0%} of {unident.sum()}" if unident.any() else "-"
            gated = sum(int(r["gated"][j]) for r in runs) / sum(int(r["gated"][2]) for r in runs)
            print(f"{sc.name:24} {sensor:6} {ratio.mean():7.3f} ± {ratio.std(ddof=1) / np.sqrt(ratio.size):5.3f} "
                  f"{np.sqrt(np.mean(rows[:, 1] ** 2)):12.3f} {np.median(rows[:, 2]):10.3f} "
                  f"{np.median(rows[:, 3]):9.3f} "
                  f"{covered.mean():12.1%} {identified.mean():10.0%} {upper:>13} {gated:6.2%} "
                  f"{int(np.median([r['dof'][j] for r in runs])):4d}")
        sys.stdout.flush()
    print(f"\nodometry noise declared in the twist covariance = the simulated noise; S_g from the odometry yaw rate "
          f"(trapezoid); medians over the axes: 'used' = the value the filter ran with (max(LS, se)), 'old' = the "
          f"value printed before issue 12 (the last positive LS, else the prior); took "
          f"{time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
