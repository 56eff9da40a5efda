"""Files and text of the offline static analysis: Kalibr ``imu.yaml``, Allan-family CSVs, the summary table.

Every writer takes a :class:`~imu_noise_id.pipelines.analysis.StaticAnalysis` and an output directory; units
are SI and written next to every number (YAML comments, CSV header lines starting with ``#``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml

from ..core.allan import AllanResult
from ..core.axes import ACCEL_AXES, GYRO_AXES, UNITS
from ..pipelines.analysis import StaticAnalysis, kalibr_parameters

#: How the one number per sensor that Kalibr wants is made from the three axes.
KALIBR_COMBINE = "max"

_KALIBR_UNITS = {
    "accelerometer_noise_density": "m/s^2/sqrt(Hz)",
    "accelerometer_random_walk": "m/s^3/sqrt(Hz)",
    "gyroscope_noise_density": "rad/s/sqrt(Hz)",
    "gyroscope_random_walk": "rad/s^2/sqrt(Hz)",
}
_PREFIX = {"gyro": "gyroscope", "accel": "accelerometer"}


def _float(x: float) -> float:
    return float(f"{x:.6g}")


def kalibr_dict(result: StaticAnalysis, rostopic: str) -> dict:
    """Kalibr ``imu.yaml`` content: its six keys plus per-axis values, CIs and methods in extra keys."""
    doc: dict = {k: _float(v) for k, v in kalibr_parameters(result, KALIBR_COMBINE).items()}
    doc["update_rate"] = _float(result.rate_hz)
    doc["rostopic"] = rostopic
    doc["confidence_level"] = result.allan.confidence
    for sensor, axes in (("gyro", GYRO_AXES), ("accel", ACCEL_AXES)):
        for parameter in ("noise_density", "random_walk"):
            key = f"{_PREFIX[sensor]}_{parameter}"
            comps = [getattr(result.slopes[a], parameter) for a in axes]
            doc[f"{key}_xyz"] = [_float(c.value) for c in comps]
            doc[f"{key}_ci_xyz"] = [[_float(c.ci[0]), _float(c.ci[1])] for c in comps]
            doc[f"{key}_method_xyz"] = [c.method for c in comps]
    return doc


def write_kalibr_yaml(result: StaticAnalysis, out_dir: Path, rostopic: str) -> Path:
    """``out_dir/imu.yaml`` in Kalibr's format (see :func:`kalibr_dict`)."""
    doc = kalibr_dict(result, rostopic)
    conf = result.allan.confidence
    header = [
        "# IMU noise parameters for Kalibr / VIO, from the Allan variance (imu-noise-id analyze).",
        "# Units: *_noise_density: gyroscope rad/s/sqrt(Hz), accelerometer m/s^2/sqrt(Hz);",
        "#        *_random_walk: gyroscope rad/s^2/sqrt(Hz), accelerometer m/s^3/sqrt(Hz); update_rate Hz.",
        f"# The four Kalibr numbers are the {KALIBR_COMBINE} over the sensor's x, y, z axes; per-axis values are in",
        "# the *_xyz keys. White noise is the -1/2 slope line read at tau = 1 s, random walk the +1/2 slope line",
        f"# at tau = 3 s; *_ci_xyz: {100 * conf:g} % confidence intervals; method upper_bound = slope not reached.",
        f"# Data: {result.n} samples, {result.duration_s:.1f} s at {result.rate_hz:.6g} Hz from {result.topic or '?'}.",
    ]
    path = out_dir / "imu.yaml"
    path.write_text("\n".join(header) + "\n" + yaml.safe_dump(doc, sort_keys=False, default_flow_style=None))
    return path


def write_variance_csv(res: AllanResult, axes: tuple[str, ...], path: Path) -> Path:
    """One Allan-family result as CSV: tau, m, then per axis the variance, CI bounds and EDF."""
    cols = ["tau_s", "m"]
    for a in axes:
        cols += [f"{a}_var", f"{a}_ci_low", f"{a}_ci_high", f"{a}_edf"]
    units = ", ".join(f"{a} [{UNITS[a]}]^2" for a in axes)
    header = [
        f"# {res.kind} variance of rate samples, dt = {res.dt:.9g} s, n = {res.n}; tau [s] = m * dt",
        f"# *_var, *_ci_low, *_ci_high in squared signal units: {units}",
        f"# *_ci_low/high: two-sided {100 * res.confidence:g} % chi-square interval; *_edf: equivalent degrees "
        "of freedom",
        ",".join(cols),
    ]
    table = np.empty((res.tau.size, len(cols)))
    table[:, 0] = res.tau
    table[:, 1] = res.m
    for j in range(len(axes)):
        table[:, 2 + 4 * j : 6 + 4 * j] = np.column_stack(
            [res.variance[:, j], res.ci_low[:, j], res.ci_high[:, j], res.edf[:, j]]
        )
    lines = [",".join(f"{v:.10g}" for v in row) for row in table]
    path.write_text("\n".join(header + lines) + "\n")
    return path


def write_variance_csvs(result: StaticAnalysis, out_dir: Path) -> list[Path]:
    """``allan.csv`` and one CSV per other computed kind (``hadamard.csv``, ``total.csv``, ``modified.csv``)."""
    return [write_variance_csv(res, result.axes, out_dir / f"{kind}.csv") for kind, res in result.variances.items()]


_SUMMARY_UNITS = {"rad/s": ("rad/s/sqrt(Hz)", "rad/s^2/sqrt(Hz)"), "m/s^2": ("m/s^2/sqrt(Hz)", "m/s^3/sqrt(Hz)")}


def _fmt(x: float) -> str:
    return f"{x:.3e}" if math.isfinite(x) else "n/a"


def summary_table(result: StaticAnalysis) -> str:
    """Short text table: per axis white-noise density and random walk with their intervals."""
    conf = 100 * result.allan.confidence
    lines = [
        f"{result.n} samples, {result.duration_s:.1f} s at {result.rate_hz:.6g} Hz ({result.topic or 'input'})",
        f"{'axis':8s} {'noise density':>13s} {f'{conf:.0f}% CI':>23s}   {'random walk':>11s} {f'{conf:.0f}% CI':>23s}"
        "  unit (N; K)",
    ]
    for a in result.axes:
        s = result.slopes[a]
        n, k = s.noise_density, s.random_walk
        k_val = ("<" if k.method == "upper_bound" else " ") + _fmt(k.value)
        n_val = ("<" if n.method == "upper_bound" else " ") + _fmt(n.value)
        u_n, u_k = _SUMMARY_UNITS[UNITS[a]]
        lines.append(
            f"{a:8s} {n_val:>13s} [{_fmt(n.ci[0])}, {_fmt(n.ci[1])}]   {k_val:>11s} [{_fmt(k.ci[0])}, {_fmt(k.ci[1])}]"
            f"  {u_n}; {u_k}"
        )
    lines.append("('<': upper bound, slope not reached in this record)")
    return "\n".join(lines)


def write_static_outputs(result: StaticAnalysis, out_dir: str | Path, rostopic: str) -> dict[str, Path]:
    """Write ``imu.yaml``, the variance CSVs and ``allan.png`` into ``out_dir`` (created); returns the paths."""
    from .plots import plot_allan_deviation

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"imu.yaml": write_kalibr_yaml(result, out, rostopic)}
    for p in write_variance_csvs(result, out):
        paths[p.name] = p
    paths["allan.png"] = plot_allan_deviation(result, out / "allan.png")
    return paths
