"""Plots of the hypothesis bank: probabilities vs time per axis, and the performance criteria (paper 002)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def plot_identify(res: dict[str, Any], path: Path) -> None:
    """Posterior probability of each hypothesis vs time, one panel per axis, γ as a dashed line."""
    axes = list(res["axes"])
    fig, panels = plt.subplots(len(axes), 1, figsize=(7, 1.8 * len(axes) + 0.6), sharex=True, squeeze=False)
    for ax, axis in zip(panels[:, 0], axes, strict=True):
        r = res["axes"][axis]["result"]
        for k, name in enumerate(r.names):
            ax.plot(r.t, r.probabilities[:, k], label=name)
        ax.axhline(r.gamma, color="k", ls="--", lw=0.8)
        ax.set_ylim(-0.02, 1.02)
        ax.set_ylabel(axis)
        ax.legend(loc="center right", fontsize=7)
    panels[-1, 0].set_xlabel("time [s]")
    fig.suptitle("Posterior probability of each hypothesis")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_criteria(results: list[Any], path: Path, title: str = "") -> None:
    """Real (solid) and calculated (dashed) identification-error probability and RSDs vs time."""
    params = sorted({p for r in results for p in r.rsd_real})
    fig, panels = plt.subplots(1, 1 + len(params), figsize=(3.3 * (1 + len(params)), 3.0), squeeze=False)
    colors = ["tab:red", "tab:green", "tab:blue", "tab:orange"]
    ax = panels[0, 0]
    for i, r in enumerate(results):
        c = colors[i % len(colors)]
        ax.plot(r.t, r.error_probability_real, color=c, label=f"case {r.case} real")
        ax.plot(r.t, r.error_probability_calculated, color=c, ls="--", label=f"case {r.case} calc.")
    ax.set_xscale("log")
    ax.set_xlabel("time [s]")
    ax.set_title("identification error probability", fontsize=9)
    ax.legend(fontsize=6)
    for j, p in enumerate(params):
        ax = panels[0, 1 + j]
        for i, r in enumerate(results):
            if p in r.rsd_real:
                c = colors[i % len(colors)]
                ax.plot(r.t, r.rsd_real[p], color=c, label=f"case {r.case} real")
                ax.plot(r.t, r.rsd_calculated[p], color=c, ls="--", label=f"case {r.case} calc.")
        ax.set_xscale("log")
        ax.set_xlabel("time [s]")
        ax.set_title(f"RSD {p}", fontsize=9)
        ax.legend(fontsize=6)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
