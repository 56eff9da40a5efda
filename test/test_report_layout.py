"""Fixed margins (report.layout): every label and title inside the figure, no panel over its neighbour."""

from __future__ import annotations

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from imu_noise_id.report.layout import fix_margins


@pytest.mark.parametrize(("rows", "cols", "size", "suptitle"),
                         [(1, 1, (7.0, 4.6), False), (2, 3, (15.0, 8.0), True), (1, 2, (9.0, 3.0), True),
                          (1, 2, (12.0, 4.8), False)])
def test_labels_and_titles_stay_inside_the_figure_and_off_the_neighbours(rows, cols, size, suptitle):
    tau = np.logspace(-2.5, 3.2, 40)
    fig, axes = plt.subplots(rows, cols, figsize=size, squeeze=False)
    for k, ax in enumerate(axes.flat):
        ax.loglog(tau, 1e-3 / np.sqrt(tau) + 1e-6 * tau)
        ax.set_xlabel("averaging time τ [s]")
        ax.set_ylabel("Allan deviation [m/s^2]")
        ax.set_title(f"accel_{k}: WN+LPF+MA+BI+3OSC+2SIN+OUTLIERS", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
    if suptitle:
        fig.suptitle("Allan deviation vs final models", fontsize=10)
    fix_margins(fig, suptitle=suptitle)
    renderer = fig.canvas.get_renderer()
    page = fig.bbox
    boxes = [ax.get_tightbbox(renderer) for ax in axes.flat]
    for box in boxes:
        assert page.x0 - 1 <= box.x0 and box.x1 <= page.x1 + 1 and page.y0 - 1 <= box.y0, box
        assert box.y1 <= page.y1 + 1, box
    if suptitle:
        title_box = fig._suptitle.get_window_extent(renderer)
        assert all(title_box.y0 >= box.y1 - 1 for box in boxes)
    for i, a in enumerate(boxes):  # labels of one panel never reach into another's plotting area
        for j, ax in enumerate(axes.flat):
            if i != j:
                assert not a.overlaps(ax.get_window_extent(renderer)), (i, j)
    plt.close(fig)
