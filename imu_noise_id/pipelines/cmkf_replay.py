"""Offline replay of a recording through the node's :class:`~.online.OnlineIdentifier` (docs/cmkf.md, "Why the replay
is the node's identifier"): IMU and odometry in stamp order, the CMKF's estimate recorded after every odometry message
it processed, the whole run judged as the node judges its windows (:func:`~imu_noise_id.core.cmkf.estimate.judge`)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from ..core.axes import ImuSeries, OdometrySeries
from ..core.cmkf.agreement import AxisAgreement, likely_cause
from ..core.cmkf.config import CmkfConfig
from ..core.cmkf.estimate import RUNNING, judge, running_status
from ..core.cmkf.gate import NisWindow
from ..core.cmkf.merge import stamp_order
from ..core.cmkf.psd import PsdEstimate, density_series
from ..core.cmkf.robot import CmkfEstimate
from ..core.cmkf.stream import orientation_rows
from ..core.diagnostics.consistency import nis_bounds
from ..core.errors import InputError
from ..core.timing import sampling_period
from .online import OnlineIdentifier

#: Per-axis values recorded over time: name → reader of a :class:`CmkfEstimate` (``S_v_in_filter``: the filter's
#: working value; ``S_v``, ``S_v_se``: the least squares and its standard error).
SERIES_FIELDS: dict[str, Callable[[CmkfEstimate], np.ndarray]] = {
    "accel_bias": lambda e: e.accel_bias, "accel_bias_std": lambda e: e.accel_bias_std,
    "S_v_in_filter": lambda e: e.S_v, "S_v": lambda e: e.accel_ls[0], "S_v_se": lambda e: e.accel_ls[1],
    "gyro_bias": lambda e: e.gyro_bias, "gyro_bias_std": lambda e: e.gyro_bias_std,
    "S_g_in_filter": lambda e: e.S_g, "S_g": lambda e: e.gyro_ls[0], "S_g_se": lambda e: e.gyro_ls[1],
}
#: Per-axis series derived after the replay (``cmkf.psd.density_series``): √S, or the 95 % upper end if unidentified.
DENSITY_FIELDS = ("accel_noise_density", "accel_noise_density_upper", "gyro_noise_density",
                  "gyro_noise_density_upper")
#: Share of the first updates the whole-run verdict leaves out (the filter converging).
RUN_SKIP = 0.2


@dataclass
class CmkfReplayResult:
    """Estimates after every odometry message the CMKF processed, the final estimate and what the filter knew.

    Attributes
    ----------
    t : (M,) stamps of those odometry messages [s]; series : field → (M, 3) (:data:`SERIES_FIELDS`,
        :data:`DENSITY_FIELDS`); nis_accel, nis_gyro : (M,) NIS of each update (also gated ones; NaN without update);
        gated_accel, gated_gyro : (M,); status : (M,) status strings.
    final : the last estimate; config : the filter's parameters; agreement : per-axis IMU/odometry agreement checks;
    gates : the NIS gates; info : rates, frames, timing; cmkf_errors : times the CMKF failed and was restarted.
    """

    t: np.ndarray
    series: dict[str, np.ndarray]
    nis_accel: np.ndarray
    nis_gyro: np.ndarray
    gated_accel: np.ndarray
    gated_gyro: np.ndarray
    status: list[str]
    final: CmkfEstimate
    config: CmkfConfig
    agreement: tuple[AxisAgreement, AxisAgreement]
    gates: tuple[float, float]
    info: dict[str, object] = field(default_factory=dict)
    cmkf_errors: int = 0


def _rate(t: np.ndarray) -> float:
    """Rate [Hz] of a stream by the package's sampling rule, 6 significant digits (nan below two usable stamps)."""
    try:
        return float(f"{1.0 / sampling_period(t):.6g}")
    except InputError:
        return math.nan


class _Recorder:
    """What the identifier's CMKF reports after each odometry message (:class:`CmkfReplayResult`'s series)."""

    def __init__(self) -> None:
        self.identifier: OnlineIdentifier | None = None
        self.t: list[float] = []
        self.series: dict[str, list[np.ndarray]] = {name: [] for name in SERIES_FIELDS}
        self.dof: list[tuple[int, int]] = []
        self.nis: list[tuple[float, float]] = []
        self.gated: list[tuple[bool, bool]] = []
        self.status: list[str] = []

    def __call__(self, t: float, updated: bool) -> None:
        cmkf = self.identifier.cmkf_feed.cmkf
        est = cmkf.estimate()
        self.t.append(t)
        for name, read in SERIES_FIELDS.items():
            self.series[name].append(read(est))
        self.dof.append((est.accel_ls[2], est.gyro_ls[2]))
        # the NIS of a filter that updated or was gated now: what its NIS window took (none at a (re-)initialisation)
        self.nis.append(tuple(nis if updated and (used or gated) else math.nan for nis, used, gated in
                              zip((est.nis_accel, est.nis_gyro), cmkf.last_update, est.gated, strict=True)))
        self.gated.append(est.gated)
        self.status.append(est.status)


def replay(
    imu: ImuSeries,
    odom: OdometrySeries | None,
    config: CmkfConfig | None = None,
    imu_orientation_xyzw: np.ndarray | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> CmkfReplayResult:
    """Feed ``imu`` and ``odom`` (None: IMU only) in stamp order to an :class:`OnlineIdentifier` whose CMKF runs with
    ``config``, then end the input (:meth:`OnlineIdentifier.finish`); odometry fields but the linear velocity may be
    None (not recorded). ``imu_orientation_xyzw`` (N, 4): each IMU message's orientation (NaN rows: none), used with
    ``gravity_source == "imu"``; ``progress(done, total)`` after every odometry message."""
    config = config or CmkfConfig()
    record = _Recorder()
    ident = record.identifier = OnlineIdentifier(cmkf=config, on_cmkf_odometry=record)
    t_start = time.perf_counter()
    _feed(ident, imu, odom, imu_orientation_xyzw, progress)
    ident.finish()
    info = _info(imu, odom, time.perf_counter() - t_start)
    series = {name: np.array(v).reshape(-1, 3) for name, v in record.series.items()}
    dofs = np.array(record.dof, dtype=int).reshape(-1, 2)
    for k, sensor, psd in ((0, "accel", "S_v"), (1, "gyro", "S_g")):
        series[f"{sensor}_noise_density"], series[f"{sensor}_noise_density_upper"] = density_series(
            series[psd], series[f"{psd}_se"], dofs[:, k:k + 1])
    nis = np.array(record.nis, dtype=float).reshape(-1, 2)
    gated = np.array(record.gated, dtype=bool).reshape(-1, 2)
    cmkf = ident.cmkf_feed.cmkf
    return CmkfReplayResult(np.array(record.t, dtype=float), series, nis[:, 0], nis[:, 1], gated[:, 0], gated[:, 1],
                            record.status, cmkf.estimate(), config, cmkf.agreement,
                            (cmkf.gates[0].threshold, cmkf.gates[1].threshold), info, ident.cmkf_feed.errors)


def _feed(ident: OnlineIdentifier, imu: ImuSeries, odom: OdometrySeries | None,
          imu_orientation_xyzw: np.ndarray | None, progress: Callable[[int, int], None] | None) -> None:
    """Every message to ``ident`` in stamp order (IMU first on equal stamps), as the node's callbacks hand them."""
    times, rows = np.asarray(imu.t, dtype=float).tolist(), np.column_stack([imu.gyro, imu.accel]).tolist()
    quats = orientation_rows(imu_orientation_xyzw)
    odom_t = [] if odom is None else np.asarray(odom.t, dtype=float).tolist()
    if odom is not None:
        linear = odom.linear_velocity.tolist()
        angular, position, orientation = (_rows(a, list) for a in (odom.angular_velocity, odom.position,
                                                                   odom.orientation_xyzw))
        pose_cov, twist_cov = (_rows(a, np.asarray) for a in (odom.pose_covariance, odom.twist_covariance))
    done = 0
    for is_odometry, k in stamp_order(np.array(times), np.array(odom_t)):
        if is_odometry:
            ident.process_odometry(odom_t[k], linear[k], angular(k), odom.child_frame_id, position=position(k),
                                   orientation_xyzw=orientation(k), pose_covariance=pose_cov(k),
                                   twist_covariance=twist_cov(k))
            done += 1
            if progress is not None:
                progress(done, len(odom_t))
        else:
            row = rows[k]
            ident.process_imu(times[k], row[0:3], row[3:6], imu.frame_id,
                              orientation_xyzw=None if quats is None else quats[k])


def _rows(a: np.ndarray | None, kind: Callable) -> Callable[[int], object]:
    """Row ``k`` of a recorded field as ``kind`` (a list, or an array view), or None for a field not recorded."""
    if a is None:
        return lambda k: None
    rows = a.tolist() if kind is list else np.asarray(a)
    return rows.__getitem__


def _info(imu: ImuSeries, odom: OdometrySeries | None, elapsed: float) -> dict[str, object]:
    """What the replay knew of its inputs (topics, frames, rates [Hz], duration [s]) and its own speed."""
    ti = np.asarray(imu.t, dtype=float)
    to = np.asarray(odom.t, dtype=float) if odom is not None else np.zeros(0)
    return {
        "imu_topic": imu.topic, "imu_frame": imu.frame_id, "imu_samples": int(ti.size), "imu_rate_hz": _rate(ti),
        "odom_topic": odom.topic if odom is not None else None,
        "odom_frame": odom.frame_id if odom is not None else None,
        "odom_child_frame": odom.child_frame_id if odom is not None else None,
        "odom_messages": int(to.size), "odom_rate_hz": _rate(to),
        "duration_s": float(max(ti[-1], to[-1] if to.size else ti[-1]) - min(ti[0], to[0] if to.size else ti[0])),
        "replay_seconds": elapsed, "imu_samples_per_second": ti.size / elapsed if elapsed > 0 else math.inf,
    }


def run_window(nis: np.ndarray, dof: int, gated: np.ndarray | None = None,
               skip_fraction: float = RUN_SKIP) -> tuple[NisWindow, np.ndarray, np.ndarray]:
    """The updates of a replay after the first ``skip_fraction`` of them as one :class:`NisWindow` (the node's
    windows hold its last ``nis_window``), with their NIS and gated flags ((K,) each; updates without NIS left out)."""
    gated = np.zeros(nis.shape, dtype=bool) if gated is None else np.asarray(gated, dtype=bool)
    keep = np.isfinite(nis) | gated
    x, g = nis[keep], gated[keep]
    start = int(skip_fraction * x.size)
    x, g = x[start:], g[start:]
    window = NisWindow(dof, None)
    for value, rejected in zip(x.tolist(), g.tolist(), strict=True):
        window.add(value, rejected)
    return window, x, g


def nis_summary(nis: np.ndarray, dof: int, gated: np.ndarray | None = None,
                skip_fraction: float = RUN_SKIP) -> dict[str, float]:
    """:func:`run_window` of a replay's NIS: mean of the accepted updates, share inside the χ²(dof) 95 % bounds,
    number and share gated, and the window's verdict."""
    return _summary(*run_window(nis, dof, gated, skip_fraction))


def _summary(window: NisWindow, x: np.ndarray, g: np.ndarray) -> dict[str, float]:
    if not window.updates:
        return {"mean": math.nan, "dof": window.dof, "share_in_95": math.nan, "n": 0, "gated": 0, "gated_share": 0.0,
                "verdict": "unknown"}
    lo, hi = nis_bounds(window.dof)
    return {"mean": window.mean, "dof": window.dof, "share_in_95": float(np.mean((x >= lo) & (x <= hi) & ~g)),
            "n": window.updates, "gated": window.gated, "gated_share": window.gated_share, "verdict": window.verdict()}
def _xyz(a: np.ndarray) -> dict[str, float | None]:
    return {k: (float(v) if math.isfinite(v) else None) for k, v in zip("xyz", a, strict=True)}


def _xyz_pairs(a: np.ndarray) -> dict[str, list[float] | None]:
    return {k: ([float(lo), float(hi)] if math.isfinite(lo) else None) for k, (lo, hi) in zip("xyz", a, strict=True)}


def psd_section(psd: PsdEstimate, prefix: str, density: str, in_filter: np.ndarray) -> dict[str, object]:
    """The ``cmkf.yaml`` keys of one sensor's PSD: estimate, standard error, intervals, verdicts, bounds."""
    return {
        prefix: _xyz(psd.value),
        f"{prefix}_se": _xyz(psd.se),
        f"{prefix}_ci95": _xyz_pairs(psd.ci95),
        f"{prefix}_dof": psd.dof,
        density: _xyz(psd.density()),
        f"{density}_ci95": _xyz_pairs(psd.density_ci95()),
        f"{density}_upper_bound": _xyz(psd.density_upper95()),
        f"{density}_verdict": dict(zip("xyz", psd.verdict, strict=True)),
        f"{prefix}_in_filter": _xyz(in_filter),
    }


def consistency_summary(result: CmkfReplayResult) -> dict[str, object]:
    """The whole run's consistency: :func:`~imu_noise_id.core.cmkf.estimate.judge` of the two filters'
    :func:`run_window` (the node's verdict over the whole run), their summaries, and the likely cause."""
    e = result.final
    runs = (run_window(result.nis_accel, e.nis_accel_dof, result.gated_accel),
            run_window(result.nis_gyro, e.nis_gyro_dof, result.gated_gyro))
    verdict, worst = judge([window for window, _, _ in runs])
    accel, gyro = (_summary(*run) for run in runs)
    reason = ""
    if verdict in ("marginal", "inconsistent"):
        window = runs[worst][0]
        generic = likely_cause(window.mean / window.dof, result.agreement)
        counted = counter_cause(e)
        cause = f"{counted}. Other possible causes: {generic}" if counted else generic
        reason = (f"accelerometer NIS mean {accel['mean']:.3g} for {accel['dof']} dof ({accel['gated']} updates "
                  f"gated), gyro NIS mean {gyro['mean']:.3g} for {gyro['dof']} dof ({gyro['gated']} gated). Likely "
                  f"cause: {cause}")
    return {"verdict": verdict, "reason": reason, "accel": accel, "gyro": gyro}


def counter_cause(e: CmkfEstimate) -> str:
    """What the filter's counters say is wrong with its odometry ("" when nothing): every message used with an
    invalid orientation, or at least as many dropped as used."""
    c = e.counters
    used, invalid = c.get("odom", 0), c.get("odom_orientation_invalid", 0)
    parts = []
    if used and invalid >= used:
        parts.append(f"every one of the {used} odometry messages used has an invalid orientation (all-zero or NaN "
                     f"quaternion; odom_orientation_invalid = {invalid}): the odometry source publishes no "
                     "orientation, and its twist and covariances may be placeholders as well: check the odometry "
                     "driver before the filter's settings")
    dropped = {k: v for k, v in c.items() if k.startswith("odom_dropped") and v}
    if dropped and sum(dropped.values()) >= used:
        parts.append(f"{sum(dropped.values())} odometry messages were dropped against {used} used ("
                     + ", ".join(f"{k} = {v}" for k, v in dropped.items()) + ")")
    return "; ".join(parts)


def replay_status(result: CmkfReplayResult, verdict: str) -> str:
    """The final status with the consistency judged over the whole run (``verdict``), by the node's rule
    (:func:`~imu_noise_id.core.cmkf.estimate.running_status`)."""
    status = result.final.status
    if status not in RUNNING:
        return status
    return running_status(result.final.n_stacked, result.config.min_samples, verdict)


def summary_lines(result: CmkfReplayResult) -> list[str]:
    """What the replay found, in sentences: consistency, biases (or why not estimated), noise per axis."""
    e = result.final
    lines = []
    verdict = consistency_summary(result)
    if verdict["verdict"] == "inconsistent":
        lines.append(f"WARNING: the filter is inconsistent: {verdict['reason']}")
    elif verdict["verdict"] == "marginal":
        lines.append(f"note: the filter is marginally consistent: {verdict['reason']}")
    if e.status in ("no_data", "no_imu", "imu_only"):
        lines.append(f"biases not estimated: {odometry_problem(e)}")
    lines += [f"accel noise density {s}" for s in e.accel_psd.describe(("x", "y", "z"), "m/s^2/sqrt(Hz)")]
    lines += [f"gyro noise density {s}" for s in e.gyro_psd.describe(("x", "y", "z"), "rad/s/sqrt(Hz)")]
    return lines


def odometry_problem(e: CmkfEstimate) -> str:
    """Why no odometry message updated the filter, from its counters."""
    c = e.counters
    if c.get("odom_dropped_orientation"):
        return (f"{c['odom_dropped_orientation']} odometry messages have no valid orientation (all-zero or NaN "
                "quaternion) and the configured filter needs one (gravity from the odometry, or pose_twist): use "
                "gravity from the IMU's orientation (--gravity-from imu) with twist measurements")
    dropped = {k: v for k, v in c.items() if k.startswith("odom_dropped") and v}
    if dropped:
        return "every odometry message was dropped (" + ", ".join(f"{k}: {v}" for k, v in dropped.items()) + ")"
    if c.get("odom_without_imu"):
        return "the odometry does not overlap the IMU samples in time"
    return "no odometry message"


def to_yaml_dict(result: CmkfReplayResult, notes: list[str] | None = None) -> dict[str, object]:
    """The ``cmkf.yaml`` content (per IMU axis x, y, z; SI units; docs/cmkf.md) plus what the filter knew: biases null
    without an odometry update, noise densities null where not identified (with their 95 % upper end where bounded)."""
    e = result.final
    estimated = e.status not in ("no_data", "no_imu", "imu_only")
    cfg = asdict(result.config)
    cfg["imu_rotation_xyzw"] = [float(v) for v in cfg["imu_rotation_xyzw"]]
    nan3 = np.full(3, math.nan)
    consistency = consistency_summary(result)
    return {
        "frame": "IMU axes (sensor frame of the Imu messages)",
        "status": replay_status(result, consistency["verdict"]),
        "observed": e.observed,
        "consistency": {"verdict": consistency["verdict"], "reason": consistency["reason"]},
        "summary": summary_lines(result),
        "accel_bias": _xyz(e.accel_bias if estimated else nan3),
        "accel_bias_std": _xyz(e.accel_bias_std if estimated else nan3),
        **psd_section(e.accel_psd, "S_v", "accel_noise_density", e.S_v),
        "gyro_bias": _xyz(e.gyro_bias if estimated else nan3),
        "gyro_bias_std": _xyz(e.gyro_bias_std if estimated else nan3),
        **psd_section(e.gyro_psd, "S_g", "gyro_noise_density", e.S_g),
        "units": {
            "accel_bias": "m/s^2", "S_v": "m^2/s^3", "accel_noise_density": "m/s^2/sqrt(Hz)",
            "gyro_bias": "rad/s", "S_g": "rad^2/s", "gyro_noise_density": "rad/s/sqrt(Hz)",
            "conventions": "S_* least squares of paper 004 eq. 35 (may be <= 0) with a block-sandwich standard "
                           "error (*_se, Student t with *_dof degrees of freedom); *_noise_density = sqrt(S) where "
                           "the 95 % interval excludes 0 (verdict identified), else null with the upper end of "
                           "the 95 % interval as *_upper_bound; *_in_filter: the working value the filter used "
                           "(prior or last positive least-squares value), not an estimate",
        },
        "n_stacked": e.n_stacked,
        "nis": {"accel": consistency["accel"], "gyro": consistency["gyro"],
                "gate": {"accel": result.gates[0], "gyro": result.gates[1],
                         "probability": result.config.nis_gate_probability}},
        "counters": e.counters,
        "filter": {**{k: v for k, v in result.info.items() if k != "replay_seconds"}, "parameters": cfg},
        "notes": list(notes or []),
    }
