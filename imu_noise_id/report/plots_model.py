"""Allan-deviation plot with the fitted model's theoretical curve and where the record's AV falls if the model holds
(paper 000 figs. 4, 6, 7: the AV of the record, thick, against the AVs of simulations of the fitted model, thin; or
the closed-form range of those simulations, :class:`~imu_noise_id.core.diagnostics.av_band.ModelAvRange`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.diagnostics.av_band import ModelAvRange
from ..core.estimation.em.results import FitResult
from .layout import fix_margins
from .png import png_bytes, write_png


def plot_allan_overlay(
    ax, tau: np.ndarray, avar: np.ndarray, fit: FitResult, band: ModelAvRange | None = None,
    *, simulations: tuple[np.ndarray, np.ndarray] | None = None, label: str = "record", unit: str = "u",
) -> None:
    """Draw the empirical Allan deviation (``tau`` [s], ``avar`` [u²]), ``fit``'s theoretical one and, with ``band``,
    the range the record's deviation falls in if the fit holds, or with ``simulations`` (τ [s], AVs (n_sim, T) [u²],
    :func:`imu_noise_id.core.simulation.bands.allan_band`) the simulated deviations, on ``ax``."""
    if band is not None:
        for k, end in enumerate((band.low, band.high)):  # lines, not a fill: the data's band stays readable under it
            ax.loglog(band.tau, np.sqrt(end), color="0.45", lw=0.9, ls="-.",
                      label=f"the fit's {100 * band.confidence:.0f} % range (χ², exact EDF)" if k == 0 else None)
    if simulations is not None:
        btau, bav = simulations
        for k, row in enumerate(bav):
            ax.loglog(btau, np.sqrt(row), color="0.7", lw=0.6, label="simulations of the fit" if k == 0 else None)
    ax.loglog(tau, np.sqrt(avar), color="k", lw=2.0, label=label)
    fine = np.exp(np.linspace(np.log(tau[0]), np.log(tau[-1]), 200))
    ax.loglog(fine, np.sqrt(fit.theoretical_allan_variance(fine)), color="C3", lw=1.4, ls="--",
              label=f"fitted {fit.model} (theory)")
    ax.set_xlabel("averaging time τ [s]")
    ax.set_ylabel(f"Allan deviation [{unit}]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)


def save_allan_overlay(path: str | Path, panels: list[dict], title: str | None = None) -> Path:
    """One PNG with a panel per entry ``{tau, avar, fit, band or simulations, label, unit, title}`` (as
    :func:`plot_allan_overlay` takes them), three to a row."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cols = min(3, len(panels))
    rows = -(-len(panels) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5.0 * cols, 4.0 * rows), squeeze=False)
    for ax in axes.flat[len(panels):]:
        ax.set_visible(False)
    for ax, panel in zip(axes.flat, panels, strict=False):
        plot_allan_overlay(ax, panel["tau"], panel["avar"], panel["fit"], panel.get("band"),
                           simulations=panel.get("simulations"), label=panel.get("label", "record"),
                           unit=panel.get("unit", "u"))
        if panel.get("title"):
            ax.set_title(panel["title"], fontsize=9)
    if title:
        fig.suptitle(title, fontsize=10)
    fix_margins(fig, suptitle=bool(title))
    return write_png(fig, path, dpi=110)


def allan_panel_png(tau: np.ndarray, avar: np.ndarray, ci: tuple[np.ndarray, np.ndarray], fit: FitResult, *,
                    band: ModelAvRange | None, lines: dict[str, tuple[float, float]],
                    unit: str, title: str, overbound: tuple[np.ndarray, np.ndarray, str] | None = None) -> bytes:
    """One readable panel (PNG bytes): the data's Allan deviation with its 95 % band, the slope lines read from it
    (``lines``: name → (exponent μ of τ in the AV, coefficient c: AV = c·τ^μ)), the final model's deviation and its
    range (``band``) and ``overbound`` (τ [s], its AV [u²], label) over its range."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.0, 4.6))
    ax.fill_between(tau, np.sqrt(ci[0]), np.sqrt(ci[1]), color="C0", alpha=0.2, lw=0, label="data 95 % band")
    plot_allan_overlay(ax, tau, avar, fit, band, label="data", unit=unit)
    for k, (name, (mu, c)) in enumerate(lines.items()):
        ax.loglog(tau, np.sqrt(c * tau**mu), color=f"C{k + 4}", lw=0.9, ls=":", label=f"{name} slope line")
    if overbound is not None:
        ob_tau, ob_av, ob_label = overbound
        ax.loglog(ob_tau, np.sqrt(ob_av), color="C1", lw=2.2, alpha=0.85, label=ob_label)
        ax.axvspan(ob_tau[0], ob_tau[-1], color="C1", alpha=0.05, lw=0)
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=7, loc="best")
    fix_margins(fig)
    return png_bytes(fig, dpi=110)
