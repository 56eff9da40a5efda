"""Figures of the offline analysis (matplotlib, Agg backend: no display needed)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from ..core.axes import ACCEL_AXES, GYRO_AXES, UNITS
from ..pipelines.analyze.static import StaticAnalysis
from .layout import fix_margins
from .png import write_png

_COLOURS = {"x": "tab:red", "y": "tab:green", "z": "tab:blue"}
_LINE_LABELS = {"QN": "quantisation", "WN": "white noise", "BI": "bias inst.", "RW": "random walk", "RR": "rate ramp"}


def plot_allan_deviation(result: StaticAnalysis, path: Path) -> Path:
    """``path`` (PNG): log-log Allan deviation of every axis with its CI band, the fitted slope lines (within a factor
    10 of their τ range) and markers for N at τ = 1 s and K at τ = 3 s."""
    res = result.allan
    tau = res.tau
    fig, panels = plt.subplots(1, 2, figsize=(12, 4.8))
    for panel, axes, title in ((panels[0], GYRO_AXES, "Gyroscope"), (panels[1], ACCEL_AXES, "Accelerometer")):
        for name in (a for a in axes if a in result.axes):  # a sensor left out of the analysis: its panel empty
            j = result.axes.index(name)
            colour = _COLOURS[name[-1]]
            panel.fill_between(tau, np.sqrt(res.ci_low[:, j]), np.sqrt(res.ci_high[:, j]), color=colour, alpha=0.15,
                               lw=0)
            panel.loglog(tau, np.sqrt(res.variance[:, j]), "o-", ms=3, lw=1.2, color=colour, label=name)
            slopes = result.slopes[name]
            for comp in slopes.components():
                lo, hi = comp.tau_range
                t_line = tau[(tau >= lo / 10) & (tau <= hi * 10)]
                if t_line.size:
                    style = ":" if comp.method == "upper_bound" else "--"
                    panel.loglog(t_line, np.sqrt(comp.line(t_line)), style, lw=0.9, color=colour, alpha=0.8)
            nd, rw = slopes.noise_density, slopes.random_walk
            panel.plot([1.0], [nd.value], "v", color=colour, ms=6)
            panel.plot([3.0], [rw.value], "^", color=colour, ms=6)
        unit = UNITS[axes[0]]
        panel.set_title(f"{title}: Allan deviation ({100 * res.confidence:.0f} % CI bands)")
        panel.set_xlabel("averaging time τ [s]")
        panel.set_ylabel(f"Allan deviation [{unit}]")
        panel.grid(True, which="both", alpha=0.3)
        if not any(a in result.axes for a in axes):
            panel.text(0.5, 0.5, "not analysed (--axis)", transform=panel.transAxes, ha="center", va="center")
            continue
        panel.legend(title="dashed: slope lines; ▼ N at 1 s, ▲ K at 3 s", fontsize=8, title_fontsize=8)
    fix_margins(fig)
    return write_png(fig, path, dpi=90)
