"""Plots of the hypothesis bank: probabilities vs time per axis, and the performance criteria (paper 002)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from ..pipelines.identify import Identification
from .png import write_png


def plot_identify(res: Identification, path: Path) -> None:
    """Posterior probability of each hypothesis vs time, one panel per axis, γ as a dashed line."""
    axes = list(res.axes)
    fig, panels = plt.subplots(len(axes), 1, figsize=(7, 1.8 * len(axes) + 0.6), sharex=True, squeeze=False)
    for ax, axis in zip(panels[:, 0], axes, strict=True):
        r = res.axes[axis].result
        for k, name in enumerate(r.names):
            ax.plot(r.t, r.probabilities[:, k], label=name)
        ax.axhline(r.gamma, color="k", ls="--", lw=0.8)
        ax.set_ylim(-0.02, 1.02)
        ax.set_ylabel(axis)
        ax.legend(loc="center right", fontsize=7)
    panels[-1, 0].set_xlabel("time [s]")
    fig.suptitle("Posterior probability of each hypothesis")
    fig.tight_layout()
    write_png(fig, path, dpi=90)


def _panel_key(name: str) -> str:
    """``"WN+GM:GM.tau"`` → ``"GM.tau (GM model)"``: the same parameter of the same model across cases."""
    hyp, _, param = name.partition(":")
    model = "RW" if "RW" in hyp.split("+") else "GM"
    return f"{param} ({model} model)"


def plot_criteria(results: list[Any], path: Path, title: str = "") -> None:
    """Real (solid) and calculated (dashed) identification-error probability and RSDs vs time."""
    panels_of: dict[str, list[tuple[Any, str]]] = {}
    for r in results:
        for name in r.rsd_real:
            panels_of.setdefault(_panel_key(name), []).append((r, name))
    keys = sorted(panels_of)
    ncols = min(3, 1 + len(keys))
    nrows = -(-(1 + len(keys)) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(3.6 * ncols, 2.8 * nrows), squeeze=False)
    flat = list(axes.ravel())
    colors = {"1": "tab:red", "2": "tab:green", "3": "tab:blue"}
    ax = flat[0]
    for r in results:
        c = colors.get(str(r.case), "k")
        ax.plot(r.t, r.error_probability_real, color=c, label=f"case {r.case} real")
        ax.plot(r.t, r.error_probability_calculated, color=c, ls="--", label=f"case {r.case} calc.")
    ax.set_title("identification error probability", fontsize=9)
    for ax, key in zip(flat[1:], keys, strict=False):
        for r, name in panels_of[key]:
            c = colors.get(str(r.case), "k")
            ax.plot(r.t, r.rsd_real[name], color=c, label=f"case {r.case} real")
            ax.plot(r.t, r.rsd_calculated[name], color=c, ls="--", label=f"case {r.case} calc.")
        ax.set_title(f"RSD {key}", fontsize=9)
    for i, ax in enumerate(flat):
        if i > len(keys):
            ax.axis("off")
            continue
        ax.set_xscale("log")
        ax.set_xlabel("time [s]", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=6)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    write_png(fig, path, dpi=80)
