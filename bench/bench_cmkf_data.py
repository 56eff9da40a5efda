"""The robot CMKF on measured data: the Husky bag (IMU 30 Hz + wheel odometry 10 Hz) and BROAD (IMU + OptiTrack).

    PYTHONPATH=. nice -n 10 python bench/bench_cmkf_data.py > docs/results/bench_cmkf_data.txt

Husky (``husky_test1.npz``): IMU mounted rotated (static_transform_publisher yaw pitch roll = −π/2 0 π/2 in
robot_localization's test launch file: gravity on +y); wheel odometry twist (body velocity) as measurement; gravity
from (a) the planar odometry orientation (roll = pitch = 0) and (b) the IMU's own orientation output. Check: the
10 s stop (t = 236.6–246.2 s) where the accelerometer mean minus gravity (IMU orientation) is bias + tilt error.

BROAD (3 trials, 285.7 Hz): the optical position is decimated to 28.6 Hz (every 10th sample) and fed as odometry
position (mode ``pose_twist``) with its velocity by central differences; the optical orientation is the IMU's
(aligned by the dataset authors), mounting = identity. Reference: the static phase before the motion, where
accelerometer mean + C_ni^T g is the bias (up to the optical orientation's error), and the Allan deviation at
τ = 1 s from the dataset README (2.2e-3 … 4.6e-3 m/s²) as the white-noise density.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from imu_noise_id.core.axes import ImuSeries, OdometrySeries
from imu_noise_id.core.cmkf import rotation as rot
from imu_noise_id.core.cmkf.config import CmkfConfig
from imu_noise_id.pipelines.cmkf_replay import CmkfReplayResult, consistency_summary, replay, replay_status
from imu_noise_id.report.cmkf_plot import plot_cmkf

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
FIG = Path(__file__).resolve().parents[1] / "docs" / "figures"
G = 9.80665


def fmt(a: np.ndarray, p: int = 4) -> str:
    return "[" + ", ".join(f"{v:.{p}g}" for v in np.asarray(a, dtype=float)) + "]"


def report(label: str, res: CmkfReplayResult, fig: Path | None = None) -> None:
    e = res.final
    consistency = consistency_summary(res)
    na, ng = consistency["accel"], consistency["gyro"]
    print(f"\n[{label}] status {replay_status(res, consistency['verdict'])}, {e.n_stacked} stacked samples, "
          f"{res.info['imu_samples_per_second']:.0f} IMU samples/s replay")
    print(f"  accel bias [m/s^2]        {fmt(e.accel_bias)} +- {fmt(e.accel_bias_std)}")
    print(f"  S_v least squares         {fmt(e.accel_psd.value, 3)} +- {fmt(e.accel_psd.se, 2)} "
          f"(in the filter {fmt(e.S_v, 3)})")
    for line in e.accel_psd.describe(("x", "y", "z"), "m/s^2/rtHz"):
        print(f"    accel {line}")
    print(f"  gyro bias [rad/s]         {fmt(e.gyro_bias)} +- {fmt(e.gyro_bias_std)}")
    print(f"  S_g least squares         {fmt(e.gyro_psd.value, 3)} +- {fmt(e.gyro_psd.se, 2)}")
    for line in e.gyro_psd.describe(("x", "y", "z"), "rad/s/rtHz"):
        print(f"    gyro {line}")
    print(f"  NIS accel: mean {na['mean']:.2f} for {na['dof']} dof, {100 * na['share_in_95']:.0f} % inside the "
          f"95 % bounds, {na['gated']} gated (last 80 % of updates); gyro: mean {ng['mean']:.2f}, "
          f"{100 * ng['share_in_95']:.0f} %, {ng['gated']} gated")
    print(f"  consistency: {consistency['verdict']}" + (f": {consistency['reason']}" if consistency["reason"] else ""))
    drop = {k: v for k, v in e.counters.items() if v and k not in ("imu", "odom", "updates")}
    print(f"  counters: imu {e.counters['imu']}, odom {e.counters['odom']}, updates {e.counters['updates']}, {drop}")
    if fig is not None:
        plot_cmkf(res, fig, title=label)


def husky() -> None:
    d = np.load(DATA / "husky_robot_localization" / "husky_test1.npz")
    imu = ImuSeries(d["imu_t"], d["imu_gyro"], d["imu_accel"], topic="/imu/data")
    m = d["odom_t"].size
    cov = np.zeros((m, 6, 6))
    cov[:, range(6), range(6)] = 1e-3  # the declared covariance (diag 1e-3; the bag's yaw entry is larger)
    odom = OdometrySeries(d["odom_t"], d["odom_pos"], d["odom_quat_xyzw"], d["odom_twist_linear"],
                          d["odom_twist_angular"], cov, cov, topic="/husky_velocity_controller/odom")
    q_bi = rot.from_ypr(-np.pi / 2, 0.0, np.pi / 2)
    print("=== Husky (robot_localization test1): 395 s, IMU 30 Hz (Microstrain 3DM-GX2), wheel odometry 10 Hz")
    results = {}
    for src in ("odometry", "imu"):
        cfg = CmkfConfig(imu_rotation_xyzw=q_bi, gravity_source=src, s_v0=1e-4)
        res = replay(imu, odom, cfg, d["imu_quat_xyzw"])
        results[src] = res
        report(f"Husky, twist, gravity from {src} orientation", res, FIG / f"cmkf_husky_{src}.png")
    # the stop: accel mean minus gravity by the IMU orientation = bias (+ orientation error)
    t = d["imu_t"]
    stop = (t > 237.5) & (t < 245.5)
    g_i = np.array([rot.to_matrix(rot.normalise(q)).T @ [0, 0, -G] for q in d["imu_quat_xyzw"][stop]])
    static = (d["imu_accel"][stop] + g_i).mean(axis=0)
    print(f"\n  stop 237.5-245.5 s: accel mean + C_ni^T g (IMU orientation) = {fmt(static)} m/s^2 "
          f"(bias + the IMU filter's tilt error x g); gyro mean = {fmt(d['imu_gyro'][stop].mean(axis=0))} rad/s")
    for src, res in results.items():
        j = np.searchsorted(res.t, 241.5)
        print(f"  filter (gravity from {src}) at t = 241.5 s: accel bias {fmt(res.series['accel_bias'][j])}, "
              f"gyro bias {fmt(res.series['gyro_bias'][j])}")


def broad(name: str, decimate: int = 10, pos_std: float = 2e-4, figure: bool = True) -> None:
    d = np.load(DATA / "broad_trials" / f"{name}.npz")
    t = d["t"]
    imu = ImuSeries(t, d["gyro"], d["accel"], topic=name)
    idx = np.arange(0, t.size, decimate)
    to = t[idx]
    p = d["opt_pos"][idx]
    q = d["opt_quat_wxyz"][idx][:, [1, 2, 3, 0]]
    dt = np.median(np.diff(to))
    v_n = np.full_like(p, np.nan)
    v_n[1:-1] = (p[2:] - p[:-2]) / (2 * dt)  # NaN wherever a neighbour is lost: the filter drops those
    v_b = np.full_like(p, np.nan)
    ok = np.all(np.isfinite(q), axis=1) & np.all(np.isfinite(v_n), axis=1)
    v_b[ok] = np.einsum("nji,nj->ni", np.array([rot.to_matrix(rot.normalise(x)) for x in q[ok]]), v_n[ok])
    m = to.size
    pose_cov = np.zeros((m, 6, 6))
    pose_cov[:, range(3), range(3)] = pos_std**2
    twist_cov = np.zeros((m, 6, 6))
    twist_cov[:, range(3), range(3)] = 2 * pos_std**2 / (2 * dt) ** 2
    twist_cov[:, range(3, 6), range(3, 6)] = 1.0  # no angular velocity given: the gyro uses the orientation
    # no angular velocity in the optical data (None): the gyro filter uses the change of orientation
    odom = OdometrySeries(to, p, q, v_b, None, pose_cov, twist_cov, topic="optitrack")
    cfg = CmkfConfig(measurement="pose_twist", s_v0=1e-4, max_odom_gap=0.5, angular_velocity_noise_std=0.01)
    res = replay(imu, odom, cfg)
    lost = int(np.sum(~np.all(np.isfinite(p), axis=1)))
    print(f"\n=== BROAD {name}: {t[-1]:.0f} s, IMU {1 / np.median(np.diff(t)):.1f} Hz, optical position at "
          f"{1 / dt:.1f} Hz ({lost} of {m} epochs lost), position sigma {pos_std} m, velocity by central differences")
    report(f"BROAD {name}, pose_twist", res, FIG / f"cmkf_{name[:8]}.png" if figure else None)
    rest = ~d["movement"] & (t < t[np.argmax(d["movement"])])
    qr = d["opt_quat_wxyz"][rest][:, [1, 2, 3, 0]]
    good = np.all(np.isfinite(qr), axis=1)
    g_i = np.array([rot.to_matrix(rot.normalise(x)).T @ [0, 0, -G] for x in qr[good]])
    static = (d["accel"][rest][good] + g_i).mean(axis=0)
    j = np.searchsorted(res.t, t[rest][-1])
    print(f"  static phase (first {t[rest][-1]:.0f} s): accel mean + C_ni^T g = {fmt(static)} m/s^2, "
          f"gyro mean = {fmt(d['gyro'][rest].mean(axis=0))} rad/s")
    print(f"  filter at the end of the static phase: accel bias {fmt(res.series['accel_bias'][j])}, "
          f"gyro bias {fmt(res.series['gyro_bias'][j])}")


def main() -> int:
    if not DATA.is_dir():
        print(f"measured data not found at {DATA}: nothing to run", file=sys.stderr)
        return 1
    FIG.mkdir(parents=True, exist_ok=True)
    husky()
    for name in ("broad_10_undisturbed_slow_translation_A", "broad_14_undisturbed_slow_translation_with_breaks_B",
                 "broad_16_undisturbed_fast_translation_B"):
        broad(name)
    print("\nS_v depends on the assumed optical noise: broad_10 again with position sigma 0.1 mm and 0.5 mm")
    for pos_std in (1e-4, 5e-4):
        broad("broad_10_undisturbed_slow_translation_A", pos_std=pos_std, figure=False)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
