"""The reference watch's detection and false alarms: a degraded gyro_z found within 60 s, an unchanged unit left alone.

Usage (from the repository root)::

    PYTHONPATH=$PWD python bench/bench_watch.py [--seeds 40] [--out docs/results/bench_watch.txt]   # ~35 min

A calibration record (20 min at 200 Hz, gyros WN + GM + RW, accelerometers WN + RW) is analyzed once by the default
``analyze`` and written as a results folder; ``read_reference`` reads it back, as ``compare --reference`` and the
node's ``reference:=`` do. Then per seed a later record of the same unit (other seeds), and in it from t = 10 min on
gyro_z degraded one way:

- ``density x1.5``: its white-noise density × 1.5;
- ``bias step 5 B`` (and ``10``): a step of 5 (10) × the bias instability B the reference's imu.yaml gives for
  gyro_z (IEEE 952: the minimum of the final model's Allan deviation σ_min / 0.664, the datasheet's "bias
  stability"). Two means of τ each differ by √2 σ_min at the best τ, so a 5 B step is ≈ 5.3 sd of the best single
  contrast, about what a scan over the step's position needs at the watch's false-alarm rate;
- ``30 Hz line 0.1 sigma`` (and ``0.2``): a sinusoid at 30 Hz whose amplitude is a tenth (a fifth) of the
  per-sample white-noise σ (N/√dt), 20 (14) dB below the noise, invisible in the samples. With 60 s of it in a 120 s
  window its periodogram ordinate is ≈ A²n/8σ² ≈ 15 (60) times the floor at 0.1 (0.2) σ, against a threshold of
  ln(M/α) ≈ 17 over the M bins at α for 0.1 false alarms per hour: 0.1 σ is at the edge of what 60 s can show.

Found within 60 s: offline, ``compare`` (``pipelines.compare``) on the record cut at 10 min + 60 s says gyro_z is
degraded with the finding of that kind; online, the node's watch (``pipelines.online.watch.ReferenceWatch``, every
sample stationary, fed one by one) has an alarm of that kind on gyro_z stamped ≤ 10 min + 60 s. False alarms: the
unchanged records whole (20 min each): any finding on any of the six axes, offline and online, per 10 h of data.
Goals (issue's targets): detection ≥ 95 % per fault; ≤ 1 false alarm per 10 h.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

from imu_noise_id.core.axes import AXES, GYRO_AXES, ImuSeries
from imu_noise_id.core.noise.components import GM, RW, WN
from imu_noise_id.core.simulation.static import simulate_static_imu
from imu_noise_id.pipelines.analyze import AnalyzeOptions, analyze
from imu_noise_id.pipelines.compare import compare
from imu_noise_id.pipelines.online.watch import ReferenceWatch
from imu_noise_id.report.analysis import write_analysis
from imu_noise_id.report.reference import Reference, read_reference

RATE_HZ = 200.0
MINUTES = 20.0
CHANGE_S = 600.0
WITHIN_S = 60.0
GYRO = [WN(1.7e-4), GM(tau=30.0, sigma=4e-5), RW(2e-5)]
ACCEL = [WN(2e-3), RW(3e-4)]
MODEL = {a: GYRO if a in GYRO_AXES else ACCEL for a in AXES}
FAULTS = ("density x1.5", "bias step 5 B", "bias step 10 B", "30 Hz line 0.1 sigma", "30 Hz line 0.2 sigma")
KIND = {"density x1.5": "noise", "bias step 5 B": "step", "bias step 10 B": "step", "30 Hz line 0.1 sigma": "line",
        "30 Hz line 0.2 sigma": "line"}
FALSE_ALARMS_PER_HOUR = 0.1  # the node's and compare's default, for the whole unit


def reference_folder(out: Path) -> tuple[Reference, float]:
    """The calibration record analyzed by the default analyze, written and read back; gyro_z's bias instability B
    [rad/s] from its imu.yaml."""
    calibration = simulate_static_imu(MODEL, RATE_HZ, MINUTES * 60.0, seed=10_000)
    write_analysis(analyze(calibration, options=AnalyzeOptions()), out, meta={})
    imu_yaml = yaml.safe_load((out / "imu.yaml").read_text())
    return read_reference(out), float(imu_yaml["gyroscope_bias_instability_xyz"][2])


def record(seed: int, fault: str | None, b: float, duration_s: float) -> ImuSeries:
    """A later record of the unit with gyro_z degraded from :data:`CHANGE_S` on by ``fault`` (None: unchanged; ``b``
    the reference's bias instability [rad/s])."""
    imu = simulate_static_imu(MODEL, RATE_HZ, duration_s, seed=seed)
    if fault is None:
        return imu
    gyro = imu.gyro.copy()
    t = imu.t - imu.t[0]
    after = t >= CHANGE_S
    rng = np.random.default_rng(seed + 50_000)
    sigma = 1.7e-4 / math.sqrt(1.0 / RATE_HZ)
    if fault == "density x1.5":
        gyro[after, 2] += rng.standard_normal(int(after.sum())) * sigma * math.sqrt(1.5**2 - 1.0)
    elif fault.startswith("bias step"):
        gyro[after, 2] += float(fault.split()[2]) * b
    else:
        gyro[after, 2] += float(fault.split()[3]) * sigma * np.sin(2 * math.pi * 30.0 * t[after])
    return ImuSeries(imu.t, gyro, imu.accel, imu.frame_id, imu.topic)


def offline(imu: ImuSeries, reference: Reference) -> dict[str, set[str]]:
    """Per axis the kinds of ``compare``'s findings ("noise", "step", "line")."""
    result = compare(imu, reference.axes, reference.rate_hz, false_alarms_per_hour=FALSE_ALARMS_PER_HOUR)
    out = {}
    for axis, c in result.axes.items():
        kinds = {k for k, found in (("noise", c.noise.sustained), ("step", c.step is not None),
                                    ("line", c.line is not None)) if found}
        if kinds:
            out[axis] = kinds
    return out


def online(imu: ImuSeries, reference: Reference) -> dict[str, dict[str, float]]:
    """Per axis the kinds of the watch's warnings and the stamp [s from the start] each was raised at (a noise alarm
    when the level after it confirmed it)."""
    watch = ReferenceWatch(reference.axes, reference.rate_hz, "calibration", ratio=1.5,
                           false_alarms_per_hour=FALSE_ALARMS_PER_HOUR)
    period = 1.0 / RATE_HZ
    samples = np.column_stack([imu.gyro, imu.accel])
    t = imu.t - imu.t[0]
    for k in range(t.size):
        watch.add(float(t[k]), samples[k], period)
    out: dict[str, dict[str, float]] = {}
    for axis, state in watch.axes().items():
        if state.confirmed_s is not None:  # the status's WARN (an alarm the level after it confirmed)
            out.setdefault(axis, {})["noise"] = state.confirmed_s
    for axis, found in watch.changes().items():
        for kind, finding in found.items():
            out.setdefault(axis, {})[kind] = finding.time_s
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=40)
    parser.add_argument("--out", type=Path, default=None, help="write the output there (default: stdout)")
    args = parser.parse_args()
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        reference, b = reference_folder(Path(tmp) / "calibration")
    lines = [f"# bench/bench_watch.py --seeds {args.seeds}",
             f"reference: default analyze of {MINUTES:g} min at {RATE_HZ:g} Hz; gyro_z final "
             f"{'+'.join(type(c).__name__ for c in reference.axes['gyro_z'].model(1 / RATE_HZ))}, N "
             f"{reference.axes['gyro_z'].noise_density:.4g} (truth 1.7e-4), bias instability B {b:.3g} rad/s",
             f"changes on gyro_z at {CHANGE_S:g} s; found = the finding of that kind on gyro_z by "
             f"{CHANGE_S + WITHIN_S:g} s",
             "", "| fault | offline compare found | online watch found | online delay median [s] | other findings |",
             "|---|---|---|---|---|"]
    cut = CHANGE_S + WITHIN_S
    for fault in FAULTS:
        kind = KIND[fault]
        found_off = found_on = other = 0
        delays = []
        for seed in range(args.seeds):
            imu = record(seed, fault, b, cut)
            off, on = offline(imu, reference), online(imu, reference)
            found_off += kind in off.get("gyro_z", set())
            stamp = on.get("gyro_z", {}).get(kind)
            if stamp is not None and stamp <= cut:
                found_on += 1
                delays.append(stamp - CHANGE_S)
            other += sum(len(v) for a, v in off.items() if a != "gyro_z") + sum(
                len(v) for a, v in on.items() if a != "gyro_z")
        lines.append(f"| {fault} | {found_off}/{args.seeds} | {found_on}/{args.seeds} | "
                     f"{np.median(delays) if delays else math.nan:.1f} | {other} |")
        print(lines[-1], file=sys.stderr, flush=True)
    alarms_off = alarms_on = 0
    for seed in range(args.seeds):
        imu = record(1_000 + seed, None, b, MINUTES * 60.0)
        alarms_off += sum(len(v) for v in offline(imu, reference).values())
        alarms_on += sum(len(v) for v in online(imu, reference).values())
    hours = args.seeds * MINUTES / 60.0
    lines += ["", f"unchanged unit, {args.seeds} records of {MINUTES:g} min ({hours:.1f} h), six axes, "
              "every test:",
              f"- offline compare: {alarms_off} false alarms ({10 * alarms_off / hours:.2f} per 10 h)",
              f"- online watch: {alarms_on} false alarms ({10 * alarms_on / hours:.2f} per 10 h)",
              "", "goals: found ≥ 95 % per fault; ≤ 1 false alarm per 10 h", "",
              f"wall {time.perf_counter() - start:.0f} s"]
    text = "\n".join(lines) + "\n"
    if args.out is None:
        print(text, end="")
    else:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
