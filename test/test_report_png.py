"""Writing report figures (report.png): log axes over a decade or more get minor ticks at 2 and 5 of each decade,
narrower ones keep matplotlib's labelled minor ticks, and every figure is closed once written."""

from __future__ import annotations

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from imu_noise_id.report.png import png_bytes, thin_log_minor_ticks, write_png


def _mantissas(locs: np.ndarray, low: float, high: float) -> set[int]:
    inside = locs[(locs >= low) & (locs <= high)]
    return {round(v / 10.0 ** np.floor(np.log10(v) + 1e-9)) for v in inside}


def test_a_log_axis_over_decades_gets_minor_ticks_at_two_and_five_only():
    fig, ax = plt.subplots()
    tau = np.logspace(-2, 3, 30)
    ax.loglog(tau, 1e-3 / np.sqrt(tau))
    thin_log_minor_ticks(fig)
    low, high = ax.get_xlim()
    assert _mantissas(ax.xaxis.get_minorticklocs(), low, high) == {2, 5}
    low, high = ax.get_ylim()
    assert _mantissas(ax.yaxis.get_minorticklocs(), low, high) == {2, 5}
    plt.close(fig)


def test_a_log_axis_within_a_decade_keeps_its_labelled_minor_ticks():
    fig, ax = plt.subplots()
    ax.semilogy([0.0, 1.0], [2.1e-3, 4.6e-3])
    before = ax.yaxis.get_minorticklocs().copy()
    thin_log_minor_ticks(fig)
    assert np.array_equal(ax.yaxis.get_minorticklocs(), before)
    fig.canvas.draw()
    labels = [t.get_text() for t in ax.yaxis.get_minorticklabels() if t.get_text()]
    assert len(labels) >= 2  # the axis has no power of ten inside: these labels are its only numbers
    plt.close(fig)


def test_figures_are_written_as_png_and_closed(tmp_path):
    fig, ax = plt.subplots()
    ax.plot([1, 2], [3, 4])
    data = png_bytes(fig, dpi=50)
    assert data.startswith(b"\x89PNG\r\n\x1a\n") and not plt.fignum_exists(fig.number)
    fig, ax = plt.subplots()
    path = write_png(fig, tmp_path / "sub" / "f.png")
    assert path.read_bytes().startswith(b"\x89PNG") and not plt.fignum_exists(fig.number)


def test_log_axes_are_labelled_with_plain_text_powers_of_ten():
    """Mathtext labels are parsed again for every figure (the cost ``bench_figures.py`` measures): the written figure's
    log axes read 10⁻², 10⁰, … as plain text, a narrow axis's minor labels too (2×10⁻³), and a linear axis is left
    alone."""
    from imu_noise_id.report.png import plain_log_labels

    fig, (wide, narrow) = plt.subplots(1, 2)
    wide.loglog(np.logspace(-2, 2, 10), np.logspace(-2, 2, 10))
    narrow.semilogy([0.0, 1.0], [2.1e-3, 4.6e-3])
    plain_log_labels(fig)
    fig.canvas.draw()
    labels = [t.get_text() for t in wide.get_xticklabels() if t.get_text()]
    assert "10⁻²" in labels and "10⁰" in labels and "10²" in labels and not any("$" in t for t in labels)
    minor = [t.get_text() for t in narrow.yaxis.get_minorticklabels() if t.get_text()]
    assert minor and all("×10⁻³" in t for t in minor)
    assert all("$" not in t.get_text() for t in narrow.get_xticklabels())
    plt.close(fig)
