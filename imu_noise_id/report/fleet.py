"""The fleet table (CSV and Parquet: one row per unit and axis) and the fleet report (HTML, self-contained), each
written to a temporary name and renamed; outliers and spec verdicts from :mod:`imu_noise_id.core.fleet`."""

from __future__ import annotations

import csv
import html
import io
import math
import os
from pathlib import Path

import numpy as np

from ..core.fleet import OUTLIER_Z, modified_z, spec_verdict
from ..pipelines.analyze.numbers import UPPER_BOUND_METHODS
from .html import STYLE, fmt, img_tag
from .layout import fix_margins
from .png import png_bytes

PARAMETERS = ("noise_density", "random_walk", "bias_instability")
COLUMNS = ("unit", "bag", "topic", "axis", "status", "error", "model", "noise_density", "noise_density_lo",
           "noise_density_hi", "noise_density_method", "random_walk", "random_walk_lo", "random_walk_hi",
           "random_walk_method", "bias_instability", "bias_instability_lo", "bias_instability_hi",
           "bias_instability_method", "source", "loop_passed", "loop_verdict", "rate_hz", "duration_s", "warnings",
           "noise_density_z", "random_walk_z", "bias_instability_z", "outlier", "spec", "spec_margin",
           "noise_spec_ratio", "noise_beyond_spec_since_s")


def annotate(rows: list[dict], spec: dict | None) -> list[dict]:
    """The rows with the modified z of each parameter within its axis, the outlier flag and the spec verdict."""
    out = [dict(r) for r in rows]
    for axis in sorted({r["axis"] for r in out if r.get("axis")}):
        same = [r for r in out if r.get("axis") == axis and r.get("status") != "failed"]
        for p in PARAMETERS:
            z = modified_z(np.array([r.get(p) if r.get(p) is not None else np.nan for r in same], dtype=float))
            for r, zi in zip(same, z, strict=True):
                r[f"{p}_z"] = None if not math.isfinite(zi) else float(zi)
    for r in out:
        flagged = [p for p in PARAMETERS if r.get(f"{p}_z") is not None and abs(r[f"{p}_z"]) > OUTLIER_Z]
        r["outlier"] = ",".join(flagged)
        limits = (spec or {}).get((r.get("axis") or "").split("_")[0], {})
        verdicts = [(p, *spec_verdict(r.get(p), r.get(f"{p}_hi"), float(limit),
                                      bound=r.get(f"{p}_method") in UPPER_BOUND_METHODS))
                    for p, limit in limits.items()]
        if r.get("noise_beyond_spec_since_s") is not None:  # the sequential test (compare --spec) holds it beyond
            verdicts.append(("noise_density beyond the limit from "
                             f"{r['noise_beyond_spec_since_s']:.0f} s, {r['noise_spec_ratio']:.3g}× it", "fail",
                             math.nan))
        if verdicts:
            order = {"fail": 0, "undecided": 1, "missing": 2, "pass": 3}
            # the worst verdict, and among equals the parameter furthest beyond its limit (the margin shown)
            worst = min(verdicts, key=lambda v: (order[v[1]], v[2] if math.isfinite(v[2]) else math.inf))
            r["spec"] = worst[1] if worst[1] == "pass" else f"{worst[1]} ({worst[0]})"
            r["spec_margin"] = min((v[2] for v in verdicts if math.isfinite(v[2])), default=None)
    return out


def _atomic(path: Path, data: bytes) -> Path:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)
    return path


def write_tables(rows: list[dict], out: Path) -> list[Path]:
    """``fleet.csv`` and ``fleet.parquet`` (columns :data:`COLUMNS`)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=COLUMNS, extrasaction="ignore")
    writer.writeheader()
    writer.writerows({c: r.get(c) for c in COLUMNS} for r in rows)
    csv_path = _atomic(out / "fleet.csv", buf.getvalue().encode())
    table = pa.table({c: pa.array([r.get(c) for r in rows], type=pa.float64() if c.endswith(
        ("density", "_lo", "_hi", "_walk", "instability", "_z", "margin", "rate_hz", "duration_s", "_ratio",
         "_since_s")) else pa.string())
        if c not in ("loop_passed",) else pa.array([r.get(c) for r in rows], type=pa.bool_()) for c in COLUMNS})
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return [csv_path, _atomic(out / "fleet.parquet", sink.getvalue().to_pybytes())]


#: Units of each plotted parameter per sensor (gyro axes in rad/s, accelerometer axes in m/s²).
UNITS = {"noise_density": ("rad/s/√Hz", "m/s²/√Hz"), "random_walk": ("rad/s²/√Hz", "m/s³/√Hz"),
         "bias_instability": ("rad/s", "m/s²")}


def spread_figure(rows: list[dict], parameter: str) -> object:
    """The spread of ``parameter`` across units: one panel per sensor (gyro, accelerometer), each on its own axis in
    its own unit (:data:`UNITS`), one column of points per axis, outliers red, a value that is an upper bound (its
    ``<parameter>_method`` in :data:`~..pipelines.analyze.numbers.UPPER_BOUND_METHODS`) an open downward triangle
    (collection label ``upper bound``) beside the measured values' dots."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    present = sorted({r["axis"] for r in rows if r.get("axis") and r.get(parameter)})
    sensors = [(name, unit, [a for a in present if a.startswith(prefix)])
               for name, prefix, unit in (("gyroscope", "gyro", UNITS[parameter][0]),
                                          ("accelerometer", "accel", UNITS[parameter][1]))]
    sensors = [s for s in sensors if s[2]]
    fig, panels = plt.subplots(1, len(sensors), figsize=(7.5, 3.6), squeeze=False)
    bounds = False
    for ax, (name, unit, axes) in zip(panels[0], sensors, strict=True):
        for i, axis in enumerate(axes):
            vals = [(r[parameter], bool(r.get("outlier") and parameter in r["outlier"]),
                     r.get(f"{parameter}_method") in UPPER_BOUND_METHODS) for r in rows
                    if r.get("axis") == axis and r.get(parameter)]
            x = np.full(len(vals), i) + np.linspace(-0.15, 0.15, len(vals))
            for bound in (False, True):
                keep = [j for j, v in enumerate(vals) if v[2] == bound]
                if not keep:
                    continue
                colours = ["C3" if vals[j][1] else "C0" for j in keep]
                ax.scatter(x[keep], [vals[j][0] for j in keep], s=18, marker="v" if bound else "o",
                           facecolors="none" if bound else colours, edgecolors=colours,
                           label="upper bound" if bound else "value")
                bounds = bounds or bound
        ax.set_yscale("log")
        ax.set_xticks(range(len(axes)), axes, fontsize=8)
        ax.tick_params(axis="y", which="both", labelsize=7)
        ax.set_ylabel(f"{parameter} [{unit}]", fontsize=8)
        ax.set_title(name, fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
    marks = "; open triangle: upper bound" if bounds else ""
    fig.suptitle(f"{parameter} across units (red: outlier, |modified z| > {OUTLIER_Z}{marks})", fontsize=9)
    # log axes spanning less than a decade label their minor ticks (3.8×10⁻⁴): room for them and the y label
    fix_margins(fig, suptitle=True, left=1.15, wspace=1.3)
    return fig


def write_fleet_report(rows: list[dict], out: Path, *, title: str, spec: dict | None) -> Path:
    """``fleet_report.html``: counts, spread plots of N, K and B per axis, outliers, spec verdicts, failures."""
    ok = [r for r in rows if r.get("status") != "failed"]
    failed = [r for r in rows if r.get("status") == "failed"]
    units = sorted({r["unit"] for r in rows})
    parts = [f"<p>{len(units)} units, {len({r['unit'] for r in failed})} failed; {len(ok)} axis rows.</p>"]
    parts += [img_tag(png_bytes(spread_figure(ok, p), dpi=100), f"spread of {p}")
              for p in PARAMETERS if any(r.get(p) for r in ok)]
    flagged = [r for r in ok if r.get("outlier")]
    items = "".join(f"<li>{html.escape(r['unit'])} {r['axis']}: {r['outlier']} (z = " + ", ".join(
        f"{fmt(r[p + '_z'], '.2f')}" for p in r["outlier"].split(",")) + ")</li>" for r in flagged) or "<li>none</li>"
    parts.append(f"<h2>Outliers</h2><ul>{items}</ul>")
    if spec:
        head = "<tr><th class=l>unit</th><th class=l>axis</th><th class=l>verdict</th><th>margin</th></tr>"
        body = "".join(f"<tr><td class=l>{html.escape(r['unit'])}</td><td class=l>{r['axis']}</td>"
                       f"<td class=l>{html.escape(str(r.get('spec', '')))}</td>"
                       f"<td>{fmt(r['spec_margin'], '.2f') if r.get('spec_margin') is not None else ''}</td></tr>"
                       for r in ok)
        parts.append(f"<h2>Against the specification</h2><p class=small>{html.escape(str(spec))}; margin = "
                     f"spec/value − 1</p><table>{head}{body}</table>")
    if failed:
        items = "".join(f"<li>{html.escape(r['unit'])}: {html.escape(r.get('error', ''))}</li>" for r in failed)
        parts.append(f"<h2>Failed units</h2><ul>{items}</ul>")
    text = (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
            f"<style>{STYLE}</style></head><body><h1>{html.escape(title)}</h1>{''.join(parts)}</body></html>")
    return _atomic(out / "fleet_report.html", text.encode())
