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


def test_the_fleet_spread_figure_keeps_its_titles_and_labels_apart():
    """The fleet report's spread of B over three units (values within a decade: minor tick labels like 3.8×10⁻⁴) drew
    its suptitle over the panels' titles, and those tick labels pushed the first panel's y label off the page; an upper
    bound was a dot like a measured value."""
    from imu_noise_id.report.fleet import spread_figure

    values = {"gyro_x": (2.9e-4, 3.7e-4, 3.4e-4), "gyro_y": (3.4e-4, 2.5e-4, 3.3e-4),
              "gyro_z": (2.2e-4, 3.5e-4, 2.1e-4), "accel_x": (4.9e-3, 4.8e-3, 4.0e-3),
              "accel_y": (1.9e-3, 3.3e-3, 2.4e-3), "accel_z": (2.8e-3, 4.6e-3, 4.8e-3)}
    rows = [{"unit": f"u{i}", "axis": axis, "bias_instability": v[i], "outlier": ""}
            for axis, v in values.items() for i in range(3)]
    fig = spread_figure(rows, "bias_instability")
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    boxes = [ax.get_tightbbox(renderer) for ax in fig.axes]
    title_box = fig._suptitle.get_window_extent(renderer)
    assert all(title_box.y0 >= box.y1 - 1 for box in boxes)
    assert all(fig.bbox.x0 - 1 <= box.x0 and box.x1 <= fig.bbox.x1 + 1 for box in boxes)  # the y label on the page
    for ax in fig.axes:
        label = ax.yaxis.label.get_window_extent(renderer)
        ticks = [t.get_window_extent(renderer) for t in ax.get_yticklabels(which="both") if t.get_text()]
        assert ticks and not any(label.overlaps(t) for t in ticks)
    assert "upper bound" not in fig._suptitle.get_text()
    plt.close(fig)
    # a bound (a B whose minimum lies beyond the record) is drawn as one, not as a measured value
    rows[0]["bias_instability_method"] = "model_upper_bound"
    fig = spread_figure(rows, "bias_instability")
    labels = [c.get_label() for c in fig.axes[0].collections]
    assert labels.count("upper bound") == 1 and "upper bound" in fig._suptitle.get_text()
    fig.canvas.draw()
    title_box = fig._suptitle.get_window_extent(fig.canvas.get_renderer())
    assert fig.bbox.x0 <= title_box.x0 and title_box.x1 <= fig.bbox.x1
    assert "upper bound" not in [c.get_label() for c in fig.axes[1].collections]
    plt.close(fig)
