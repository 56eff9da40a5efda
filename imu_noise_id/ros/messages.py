"""The node's message conventions shared by its publishers and its readers (``imu-noise-id monitor``, the tests).

``~/noise`` and ``~/hypotheses`` are ``std_msgs/Float64MultiArray`` tables whose dimensions carry their labels:
``layout.dim[0].label = "axis:gyro_x,gyro_y,…"`` (rows) and ``layout.dim[1].label = "<name>:<column 1>,…"``.
"""

from __future__ import annotations

from std_msgs.msg import Float64MultiArray, MultiArrayDimension


def labelled_layout(msg: Float64MultiArray, rows_name: str, rows: tuple[str, ...], cols_name: str,
                    cols: tuple[str, ...]) -> None:
    """Fill ``msg.layout`` of a row-major ``len(rows)`` × ``len(cols)`` table (labels: module docstring)."""
    msg.layout.dim = [
        MultiArrayDimension(label=f"{rows_name}:{','.join(rows)}", size=len(rows), stride=len(rows) * len(cols)),
        MultiArrayDimension(label=f"{cols_name}:{','.join(cols)}", size=len(cols), stride=len(cols)),
    ]
    msg.layout.data_offset = 0


def parse_labelled(msg: Float64MultiArray) -> tuple[list[str], list[str], list[list[float]]]:
    """Inverse of :func:`labelled_layout`: (row labels, column labels, rows of values)."""
    dims = msg.layout.dim
    rows = dims[0].label.split(":", 1)[1].split(",")
    cols = dims[1].label.split(":", 1)[1].split(",")
    data = [float(v) for v in msg.data]
    ncol = len(cols)
    return rows, cols, [data[i * ncol:(i + 1) * ncol] for i in range(len(rows))]
