"""Diagnostics of the online identification: levels, :class:`DiagnosticStatus` and one function per status, called
once per diagnostics period (published on ``/diagnostics`` as ``<node>: <name>``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...core.axes import ACCEL_AXES, AXES, GYRO_AXES
from ...core.cmkf.robot import CmkfEstimate
from .config import OnlineConfig
from .inputs import Input
from .results import Estimates, HypothesesReport
from .stationarity import StationaryGate

# Diagnostic levels, equal to diagnostic_msgs/DiagnosticStatus.{OK, WARN, ERROR, STALE}.
OK, WARN, ERROR, STALE = 0, 1, 2, 3
LEVEL_NAMES = {OK: "OK", WARN: "WARN", ERROR: "ERROR", STALE: "STALE"}


@dataclass
class DiagnosticStatus:
    """One diagnostics entry: ``name``, ``level`` (OK, WARN, ERROR, STALE), ``message`` and key–value details."""

    name: str
    level: int
    message: str
    values: dict[str, str] = field(default_factory=dict)


@dataclass
class WindowStats:
    """Percentiles over the last ``size`` values of a stream of numbers (processing times, NIS)."""

    size: int = 4096
    _buf: np.ndarray | None = None
    _i: int = 0
    count: int = 0

    def add(self, value: float) -> None:
        if self._buf is None or self._buf.shape[0] != self.size:
            self._buf = np.empty(self.size)
            self._i = 0
        self._buf[self._i] = value
        self._i = (self._i + 1) % self.size
        self.count += 1

    def values(self) -> np.ndarray:
        if self._buf is None:
            return np.empty(0)
        return self._buf[: min(self.count, self.size)]

    def percentile(self, q: float) -> float:
        v = self.values()
        return float(np.percentile(v, q)) if v.size else math.nan


def input_status(name: str, source: Input, wall_now: float, window_s: float,  # noqa: PLR0911, PLR0917
                 expected_rate: float, required: bool, stale_timeout: float) -> DiagnosticStatus:
    """Rate received over the period, staleness (steady clock), expected rate, frame changes of one input."""
    stats, stamps = source.stats, source.stamps
    rate = stats.window_received / window_s if window_s > 0 else math.nan
    values = {
        "received": str(stats.received),
        "accepted": str(stats.accepted),
        "rate_received_hz": f"{rate:.2f}",
        "rate_header_hz": f"{stamps.rate:.3f}",
        "rejected_nonfinite": str(stats.rejected_values),
        "frame_id": stats.frame_id or "",
        "frame_id_changes": str(stats.frame_changes),
        "saturated_samples": str(stats.saturated),
    }
    if stats.last_wall is None:
        level = STALE if required else WARN
        message = "no message received yet"
        if name.startswith("Odometry"):
            message += ": no CMKF update; stationarity from the IMU alone"
        return DiagnosticStatus(name, level, message, values)
    silent = wall_now - stats.last_wall
    values["seconds_since_last"] = f"{silent:.2f}"
    if silent > stale_timeout:
        return DiagnosticStatus(name, STALE if required else WARN, f"no message for {silent:.1f} s", values)
    if stats.window_received == 0:
        return DiagnosticStatus(name, WARN, f"no message in the last {window_s:.1f} s (the last {silent:.1f} s ago)",
                                values)
    if expected_rate > 0 and rate < 0.8 * expected_rate:
        return DiagnosticStatus(name, WARN, f"rate {rate:.1f} Hz below the expected {expected_rate:g} Hz", values)
    if stats.window_saturated:
        return DiagnosticStatus(name, WARN, f"{stats.window_saturated} sample(s) at the sensor's full scale in the "
                                f"last period (saturation; {stats.saturated} in all)", values)
    if stats.window_frame_changes:
        return DiagnosticStatus(name, WARN, f"frame_id changed {stats.window_frame_changes} time(s) in the last "
                                f"period, now {stats.frame_id!r} ({stats.frame_changes} in all)", values)
    return DiagnosticStatus(name, OK, f"{rate:.1f} Hz", values)


def stamp_status(window_counts: dict[str, int], inputs: tuple[Input, ...], restarts: int) -> DiagnosticStatus:
    """The period's stamp and value problems of every input, and the totals as values (the CMKF's and the
    saturation counts have their own statuses)."""
    window_counts = {k: v for k, v in window_counts.items()
                     if k.split("_")[0] in {s.what for s in inputs} and k != "imu_saturated"}
    values = {f"window_{k}": str(v) for k, v in sorted(window_counts.items())}
    for source in inputs:
        for k, v in source.stamps.counts.items():
            if k != "ok":
                values[f"total_{source.what}_{k}"] = str(v)
    values["restarts"] = str(restarts)
    if window_counts:
        summary = ", ".join(f"{v} {k.replace('_', ' ')}" for k, v in sorted(window_counts.items()))
        return DiagnosticStatus("Time stamps", WARN, f"in the last period: {summary}", values)
    return DiagnosticStatus("Time stamps", OK, "monotonic, no gaps", values)


def stationarity_status(gate: StationaryGate, last_imu_t: float, imu_current: bool = True) -> DiagnosticStatus:
    """Informational: stationary or not, and the evidence; nothing runs while the IMU input is silent."""
    st = gate.detector
    values = {
        "stationary": str(st.stationary).lower(),
        "imu_still": str(st.imu_still).lower(),
        "odometry_fresh": str(st.odom_fresh).lower(),
        "odometry_still": str(st.odom_still).lower(),
        "transitions": str(gate.transitions),
    }
    if not imu_current:
        return DiagnosticStatus("Stationarity", OK, "no current IMU input: identification paused", values)
    if st.stationary:
        held = last_imu_t - st.stationary_since
        values["stationary_for_s"] = f"{held:.1f}"
        return DiagnosticStatus("Stationarity", OK, f"stationary for {held:.1f} s: identification running", values)
    return DiagnosticStatus("Stationarity", OK, "moving or settling: identification paused", values)


#: The per-period counts of updates the CMKF's innovation gate rejected, and which filter.
GATED_COUNTS = (("cmkf_gated_accel", "accelerometer"), ("cmkf_gated_gyro", "gyro"))


def consistency_status(est: CmkfEstimate, window_counts: dict[str, int], errors: int,  # noqa: PLR0911
                       too_late: int) -> DiagnosticStatus:
    """The CMKF's consistency: its verdict over the last ``nis.window`` updates (NIS against χ² bounds, updates
    rejected by the innovation gate) with the likely cause, the period's gated updates, why it is not running."""
    c = est.counters
    values = {"cmkf_status": est.status, "updates": str(c.get("updates", 0)),
              "stacked_samples": str(est.n_stacked), "nis_accel_mean": f"{est.nis_accel_mean:.3f}",
              "nis_accel_dof": str(est.nis_accel_dof), "nis_gyro_mean": f"{est.nis_gyro_mean:.3f}",
              "nis_gyro_last": f"{est.nis_gyro:.3f}", "consistency": est.consistency}
    for key, count in c.items():
        if count and key not in ("imu", "odom", "updates"):
            values[f"cmkf_{key}"] = str(count)
    name = "Filter consistency"
    values["cmkf_restarts_after_errors"] = str(errors)
    values["odom_too_late_for_cmkf"] = str(too_late)
    gated = [f"{window_counts[key]} {what} update(s)" for key, what in GATED_COUNTS if window_counts.get(key)]
    gated_text = (f"; rejected by the innovation gate in the last period: {' and '.join(gated)} (a bump, a "
                  "saturated or corrupted sample, wheel slip)") if gated else ""
    if window_counts.get("cmkf_error"):
        return DiagnosticStatus(name, ERROR, "the CMKF raised an error and was restarted (see the log)", values)
    if est.status in ("no_data", "no_imu", "imu_only"):
        reason = ""
        if c.get("odom_dropped_orientation"):
            reason = (f": {c['odom_dropped_orientation']} odometry messages dropped, their orientation is invalid "
                      "(all-zero quaternion) and cmkf.gravity_source odometry needs it (use imu)")
        elif c.get("odom_dropped_nan") or c.get("odom_dropped_missing"):
            reason = ": odometry messages dropped (non-finite or missing fields, see the values)"
        return DiagnosticStatus(name, WARN, f"CMKF not running ({est.status.replace('_', ' ')}): it needs "
                                f"IMU and odometry{reason}", values)
    if est.status == "unobserved":
        return DiagnosticStatus(name, WARN, "no odometry update recently: biases are predicted only", values)
    if est.consistency == "inconsistent":
        return DiagnosticStatus(name, ERROR, f"filter inconsistent, biases not to be trusted: "
                                f"{est.consistency_reason}{gated_text}", values)
    if est.consistency == "marginal":
        return DiagnosticStatus(name, WARN, f"marginally consistent: {est.consistency_reason}{gated_text}", values)
    if gated:
        return DiagnosticStatus(name, WARN, gated_text.removeprefix("; ").capitalize(), values)
    if est.consistency == "unknown":
        return DiagnosticStatus(name, OK, f"converging ({c.get('updates', 0)} updates)", values)
    return DiagnosticStatus(name, OK, f"NIS mean {est.nis_accel_mean:.2f} (accelerometer, {est.nis_accel_dof} dof), "
                            f"{est.nis_gyro_mean:.2f} (gyro, 3 dof): consistent", values)


def cmkf_noise_status(est: CmkfEstimate) -> DiagnosticStatus:
    """What the CMKF's covariance matching says about S_g and S_v per axis: estimate with interval, or why not."""
    name = "CMKF noise"
    if est.status in ("no_data", "no_imu", "imu_only"):
        return DiagnosticStatus(name, OK, "no odometry: nothing estimated")
    values = {}
    lines = []
    for sensor, psd, unit in (("gyro", est.gyro_psd, "rad/s/sqrt(Hz)"), ("accel", est.accel_psd, "m/s^2/sqrt(Hz)")):
        axes = tuple(f"{sensor}_{a}" for a in "xyz")
        lines += psd.describe(axes, unit)
        for axis, verdict in zip(axes, psd.verdict, strict=True):
            values[f"{axis}_verdict"] = verdict
    identified = sum(v == "identified" for v in (*est.gyro_psd.verdict, *est.accel_psd.verdict))
    return DiagnosticStatus(name, OK, f"{identified}/6 axes identified. " + "; ".join(lines), values)


def noise_status(est: Estimates, needed: int) -> DiagnosticStatus:
    """Stationary samples collected and the densities once there are enough."""
    n = est.noise_samples
    values = {"stationary_samples": str(n), "needed": str(needed), "covariance_source": est.covariance_source}
    if n < needed:
        return DiagnosticStatus("Noise density", WARN, f"collecting stationary samples ({n}/{needed}); "
                                f"corrected IMU covariance from: {est.covariance_source}", values)
    for axis, value in zip(AXES, est.noise_density, strict=True):
        values[f"{axis}_noise_density"] = f"{value:.4g}"
    values["relative_std"] = f"{est.noise_density_rstd:.3g}"
    return DiagnosticStatus("Noise density", OK, f"estimated from {n} stationary samples", values)


def hypotheses_status(report: HypothesesReport | None, enabled: bool, decision_changes: list[str]
                      ) -> DiagnosticStatus:
    """Decisions per axis; WARN in a period in which a decision changed."""
    name = "Hypotheses"
    if not enabled:
        return DiagnosticStatus(name, OK, "hypothesis bank disabled (hypotheses.enabled: false)")
    if report is None:
        return DiagnosticStatus(name, OK, "waiting for stationary samples")
    values = {}
    decided = []
    for i, axis in enumerate(AXES):
        k = int(report.decision[i])
        values[f"{axis}_decision"] = report.names[k] if k >= 0 else "undecided"
        values[f"{axis}_updates"] = str(int(report.updates[i]))
        if report.notes[i]:
            values[f"{axis}_indistinguishable"] = report.notes[i]
        if k >= 0:
            decided.append(f"{axis} {report.names[k]}")
    if decision_changes:
        return DiagnosticStatus(name, WARN, "; ".join(decision_changes), values)
    if len(decided) == 6:
        return DiagnosticStatus(name, OK, "decided: " + ", ".join(decided), values)
    return DiagnosticStatus(name, OK, f"{len(decided)}/6 axes decided", values)


def range_status(config: OnlineConfig, est: Estimates) -> DiagnosticStatus:
    """Biases and noise densities against the ``expected.*`` bounds."""
    cfg = config
    problems = []
    for axis, value in zip(GYRO_AXES, est.gyro_bias, strict=True):
        if abs(value) > cfg.expected_gyro_bias_max:
            problems.append(f"{axis} bias {value:.3g} rad/s > {cfg.expected_gyro_bias_max:g}")
    for axis, value in zip(ACCEL_AXES, est.accel_bias, strict=True):
        if abs(value) > cfg.expected_accel_bias_max:
            problems.append(f"{axis} bias {value:.3g} m/s^2 > {cfg.expected_accel_bias_max:g}")
    for axis, value in zip(AXES, est.noise_density, strict=True):
        limit = cfg.expected_gyro_noise_density_max if axis in GYRO_AXES else cfg.expected_accel_noise_density_max
        if value > limit:
            problems.append(f"{axis} noise density {value:.3g} > {limit:g}")
    values = {"problems": str(len(problems))}
    if problems:
        return DiagnosticStatus("Estimate ranges", WARN, "; ".join(problems), values)
    return DiagnosticStatus("Estimate ranges", OK, "estimates inside the expected ranges", values)


def processing_status(processing_time: WindowStats, identification_time: WindowStats) -> DiagnosticStatus:
    """Callback and bank-batch times (informational)."""
    pt, it = processing_time, identification_time
    values = {
        "callbacks": str(pt.count),
        "callback_p50_us": f"{pt.percentile(50) * 1e6:.1f}",
        "callback_p99_us": f"{pt.percentile(99) * 1e6:.1f}",
        "callback_max_us": f"{float(pt.values().max()) * 1e6:.1f}" if pt.count else "nan",
        "bank_batches": str(it.count),
        "bank_batch_p50_us": f"{it.percentile(50) * 1e6:.1f}",
        "bank_batch_max_us": f"{float(it.values().max()) * 1e6:.1f}" if it.count else "nan",
    }
    if not pt.count:
        return DiagnosticStatus("Processing", OK, "no IMU callback yet", values)
    return DiagnosticStatus("Processing", OK, f"p99 {values['callback_p99_us']} us per IMU callback", values)
