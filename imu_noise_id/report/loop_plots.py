"""Figures of the closed loop as PNG bytes (optionally also saved): Allan deviation of data vs model before/after a
step, residual ACF and PSD."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..pipelines.loop import LoopStep
from .layout import fix_margins
from .png import png_bytes


def _figure(width: float = 6.4, height: float = 3.4, ncols: int = 1):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, ncols, figsize=(width, height), dpi=80)
    return fig, axes


def _png(fig, path: Path | None, *, suptitle: bool = False) -> bytes:
    fix_margins(fig, suptitle=suptitle)
    data = png_bytes(fig)
    if path is not None:
        Path(path).write_bytes(data)
    return data


def allan_before_after(before: LoopStep, after: LoopStep | None, unit: str = "u", title: str = "",
                       path: Path | None = None) -> bytes:
    """ADEV of the data (95 % band) with the model's theoretical ADEV, before and (if given) after a step."""
    fig, ax = _figure()
    for step, colour, label in ((before, "tab:blue", "before"), (after, "tab:red", "after")):
        if step is None:
            continue
        d = step.diagnosis
        ax.fill_between(d.tau, np.sqrt(d.av_ci[0]), np.sqrt(d.av_ci[1]), color=colour, alpha=0.15, lw=0)
        ax.loglog(d.tau, np.sqrt(d.av_data), "o", ms=3, color=colour, label=f"data ({label}: {step.model})")
        ax.loglog(d.tau, np.sqrt(d.av_model), "-", color=colour,
                  label=f"model, AV misfit {step.errors.av_misfit:.3f}")
    ax.set_xlabel("τ [s]")
    ax.set_ylabel(f"Allan deviation [{unit}]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title(title, fontsize=9)
    return _png(fig, path)


def residual_acf_psd(step: LoopStep, title: str = "", path: Path | None = None) -> bytes:
    """Autocorrelation (with its ±1.96/√n band) and Welch PSD of the standardised innovations of a step."""
    s = step.diagnosis.spectra
    fig, (a1, a2) = _figure(9.0, 3.0, ncols=2)
    a1.bar(s.lags, s.acf, width=0.8, color="tab:gray")
    a1.axhline(s.band, color="tab:red", ls="--", lw=0.8)
    a1.axhline(-s.band, color="tab:red", ls="--", lw=0.8)
    a1.set_xlabel("lag [samples]")
    a1.set_ylabel("ACF of std. innovations")
    a1.set_title(f"Ljung–Box p = {step.errors.ljung_box_p:.2g}", fontsize=9)
    a2.loglog(s.frequency, s.psd, lw=0.7)
    a2.axhline(s.white_level, color="tab:red", ls="--", lw=0.8, label="white, unit variance")
    a2.set_xlabel("frequency [Hz]")
    a2.set_ylabel("PSD [1/Hz]")
    a2.set_title(f"peak ratio {step.errors.peak_ratio:.1f} at {step.errors.peak_frequency:.3g} Hz", fontsize=9)
    a2.legend(fontsize=7)
    fig.suptitle(title, fontsize=9)
    return _png(fig, path, suptitle=bool(title))
