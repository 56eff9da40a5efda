"""Plot of the CMKF replay: biases with ±2σ, √S_v and √S_g, and the NIS against its χ² 95 % bounds."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.diagnostics.consistency import nis_bounds
from ..pipelines.cmkf_replay import CmkfReplayResult
from .png import write_png


def plot_cmkf(result: CmkfReplayResult, path: Path, title: str = "") -> None:
    """Write a 4-panel PNG of ``result`` to ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = result.t - (result.t[0] if result.t.size else 0.0)
    s = result.series
    fig, axs = plt.subplots(4, 1, figsize=(8, 10), sharex=True)
    colors = ("C0", "C1", "C2")
    for i, axis in enumerate("xyz"):
        b, sd = s["accel_bias"][:, i], s["accel_bias_std"][:, i]
        axs[0].plot(t, b, colors[i], lw=1, label=f"accel {axis}")
        axs[0].fill_between(t, b - 2 * sd, b + 2 * sd, color=colors[i], alpha=0.2)
        g, gs = s["gyro_bias"][:, i], s["gyro_bias_std"][:, i]
        axs[1].plot(t, g, colors[i], lw=1, label=f"gyro {axis}")
        axs[1].fill_between(t, g - 2 * gs, g + 2 * gs, color=colors[i], alpha=0.2)
        axs[2].semilogy(t, s["accel_noise_density"][:, i], colors[i], lw=1, label=f"√S_v {axis} [m/s²/√Hz]")
        axs[2].semilogy(t, s["accel_noise_density_upper"][:, i], colors[i], lw=0.8, ls=":")
        axs[2].semilogy(t, s["gyro_noise_density"][:, i], colors[i], lw=1, ls="--", label=f"√S_g {axis} [rad/s/√Hz]")
        axs[2].semilogy(t, s["gyro_noise_density_upper"][:, i], colors[i], lw=0.8, ls="-.")
    axs[0].set_ylabel("accel bias [m/s²]\n(±2σ)")
    axs[1].set_ylabel("gyro bias [rad/s]\n(±2σ)")
    axs[2].set_ylabel("noise density\n(dotted: 95 % upper\nbound, not identified)")
    dof_a, dof_g = result.final.nis_accel_dof, result.final.nis_gyro_dof
    axs[3].semilogy(t, result.nis_accel, ".", ms=1.5, color="C0", label=f"NIS accel ({dof_a} dof)")
    axs[3].semilogy(t, result.nis_gyro, ".", ms=1.5, color="C3", alpha=0.5, label=f"NIS gyro ({dof_g} dof)")
    lo, hi = nis_bounds(dof_a)
    axs[3].axhline(lo, color="k", lw=0.6, ls=":")
    axs[3].axhline(hi, color="k", lw=0.6, ls=":", label=f"χ²({dof_a}) 95 % bounds")
    axs[3].set_ylabel("NIS")
    axs[3].set_xlabel("time from the first odometry message [s]")
    for ax in axs:
        ax.legend(fontsize=7, loc="upper right", ncol=3)
        ax.grid(alpha=0.3)
    axs[0].set_title(title or "CMKF replay (IMU axes)")
    finite = np.isfinite(result.nis_accel)
    if finite.any():
        axs[3].set_ylim(max(1e-3, np.nanpercentile(result.nis_accel[finite], 0.5)), None)
    fig.tight_layout()
    write_png(fig, path, dpi=80)
