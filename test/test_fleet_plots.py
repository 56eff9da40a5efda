"""The fleet report's spread plots keep rad/s and m/s² apart: a panel per sensor, each labelled with its unit."""

from __future__ import annotations

import matplotlib.pyplot as plt

from imu_noise_id.report.fleet import spread_figure


def _rows() -> list[dict]:
    rows = []
    for unit, scale in (("u1", 1.0), ("u2", 1.1), ("u3", 5.0)):
        rows += [{"unit": unit, "axis": axis, "noise_density": value * scale,
                  "outlier": "noise_density" if scale > 2 else ""}
                 for axis, value in (("gyro_x", 1.7e-4), ("gyro_z", 1.8e-4), ("accel_x", 2e-3), ("accel_y", 2.1e-3))]
    return rows


def test_gyro_and_accelerometer_values_are_on_separate_labelled_axes():
    fig = spread_figure(_rows(), "noise_density")
    gyro, accel = fig.axes
    assert gyro.get_ylabel() == "noise_density [rad/s/√Hz]" and accel.get_ylabel() == "noise_density [m/s²/√Hz]"
    assert [t.get_text() for t in gyro.get_xticklabels()] == ["gyro_x", "gyro_z"]
    assert [t.get_text() for t in accel.get_xticklabels()] == ["accel_x", "accel_y"]
    points = [float(y) for ax in (gyro, accel) for c in ax.collections for y in c.get_offsets()[:, 1]]
    assert max(points[:6]) < 1e-3 < min(points[6:])  # no m/s² value among the rad/s ones
    plt.close(fig)


def test_one_sensor_alone_gets_one_panel():
    rows = [r for r in _rows() if r["axis"].startswith("accel")]
    fig = spread_figure(rows, "noise_density")
    assert len(fig.axes) == 1 and fig.axes[0].get_title() == "accelerometer"
    plt.close(fig)
