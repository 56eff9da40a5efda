"""The robot CMKF on simulated moving robots (turning, accelerating, IMU rotated y-up), several seeds.

    PYTHONPATH=. nice -n 10 python bench/bench_cmkf_robot_sim.py > docs/results/bench_cmkf_robot_sim.txt

Truth: S_v = 1e-4 m²/s³ (0.01 m/s²/√Hz), S_g = 1e-6 rad²/s, accel bias (0.05, −0.08, 0.03) m/s², gyro bias
(0.002, −0.003, 0.001) rad/s; IMU 100 Hz, odometry 10 Hz with σ_v = 2 mm/s, σ_ω = 2 mrad/s; 300 s per run.
"""

from __future__ import annotations

import numpy as np

from imu_noise_id.core.cmkf.config import CmkfConfig
from imu_noise_id.core.cmkf.robot import RobotCmkf
from imu_noise_id.core.simulation.robot import replay_arrays, simulate_robot


def main() -> None:
    seeds = range(8)
    print(f"{'seed':>4} {'mode':>10} | accel bias error / sigma (x, y, z) | S_v/S_v_true (x, y, z) | "
          "NIS accel mean (dof) | gyro bias error / sigma | NIS gyro")
    rows = []
    for seed in seeds:
        run = simulate_robot(300.0, np.random.default_rng(100 + seed))
        for mode in ("twist", "pose_twist"):
            f = RobotCmkf(CmkfConfig(imu_rotation_xyzw=run.imu_rotation_xyzw, measurement=mode, s_v0=2e-4))
            est = replay_arrays(f, run)
            e = est[-1]
            zb = (e.accel_bias - run.accel_bias) / e.accel_bias_std
            zg = (e.gyro_bias - run.gyro_bias) / e.gyro_bias_std
            sv = e.S_v / 1e-4
            nis = np.mean([x.nis_accel for x in est[1000:]])
            nisg = np.mean([x.nis_gyro for x in est[1000:]])
            rows.append((mode, zb, sv, nis, zg, nisg))
            print(f"{seed:>4} {mode:>10} | {np.array2string(zb, precision=2):>30} | "
                  f"{np.array2string(sv, precision=3):>22} | {nis:6.2f} ({e.nis_accel_dof}) | "
                  f"{np.array2string(zg, precision=2):>22} | {nisg:5.2f}")
    for mode in ("twist", "pose_twist"):
        r = [x for x in rows if x[0] == mode]
        zb = np.array([x[1] for x in r])
        sv = np.array([x[2] for x in r])
        print(f"\n{mode}: accel bias error/sigma rms {np.sqrt(np.mean(zb**2)):.2f} (1 = consistent); "
              f"S_v ratio mean {sv.mean():.3f}, rms relative error {np.sqrt(np.mean((sv - 1) ** 2)):.3f}, "
              f"max |rel. error| {np.abs(sv - 1).max():.3f}; mean NIS {np.mean([x[3] for x in r]):.2f}; "
              f"gyro bias error/sigma rms {np.sqrt(np.mean(np.array([x[4] for x in r]) ** 2)):.2f}")


if __name__ == "__main__":
    main()
