"""A live terminal view of a running ``imu_noise_id_node`` (``imu-noise-id monitor``): :class:`Listener` subscribes
to its outputs and its ``/diagnostics`` statuses; :func:`watch` redraws in place (ANSI), :func:`snapshot` prints one
screen; :func:`render` is a pure function of :class:`MonitorState`.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field

from ..core.axes import AXES
from ..core.errors import InputError
from ..pipelines.online import LEVEL_NAMES
from ..pipelines.online.results import HYPOTHESES_EXTRA_COLUMNS, decision_text

#: ANSI colour per diagnostics level (OK, WARN, ERROR, STALE = 0, 1, 2, 3).
_COLOURS = {0: "\x1b[32m", 1: "\x1b[33m", 2: "\x1b[31m", 3: "\x1b[35m"}


@dataclass
class MonitorState:
    """The latest outputs of one node, as plain values."""

    node: str
    gyro_bias: tuple[float, float, float] | None = None
    accel_bias: tuple[float, float, float] | None = None
    noise: tuple[list[str], list[str], list[list[float]]] | None = None
    hypotheses: tuple[list[str], list[str], list[list[float]]] | None = None
    diagnostics: dict[str, tuple[int, str]] = field(default_factory=dict)
    stamp: float = math.nan

    def complete(self) -> bool:
        """True once biases, noise and diagnostics have all been received."""
        return self.gyro_bias is not None and self.accel_bias is not None and self.noise is not None and bool(
            self.diagnostics)


def _fmt(value: float, width: int = 10) -> str:
    if value is None or not math.isfinite(value):
        return "—".rjust(width)
    return f"{value:{width}.3e}"


def column(table: tuple[list[str], list[str], list[list[float]]] | None, name: str) -> list[float]:
    """Column ``name`` of a labelled table (one value per axis; NaN where the table or the column is missing)."""
    if table is None or name not in table[1]:
        return [math.nan] * 6
    j = table[1].index(name)
    return [row[j] for row in table[2]]


def render(state: MonitorState, colour: bool = False) -> str:
    """The screen for ``state``: biases ± 1σ, noise figures, hypothesis probabilities, diagnostics."""
    lines = [f"imu_noise_id monitor — node {state.node}   (header time {state.stamp:.2f} s)", ""]
    bias = column(state.noise, "bias")
    bias_std = column(state.noise, "bias_std")
    density = column(state.noise, "noise_density")
    cov = column(state.noise, "covariance")
    cmkf_density = column(state.noise, "cmkf_noise_density")
    cmkf_upper = column(state.noise, "cmkf_noise_density_upper")
    lines.append(f"{'axis':8} {'bias':>10} {'± 1σ':>10} {'N stat.':>10} {'N cmkf':>10} {'cov N²f':>10}"
                 f"   unit, N in unit/√Hz (N cmkf '<x': not identifiable, below x)")
    for i, axis in enumerate(AXES):
        unit = "rad/s" if axis.startswith("gyro") else "m/s²"
        n_cmkf = (f"<{cmkf_upper[i]:.2e}".rjust(10) if not math.isfinite(cmkf_density[i])
                  and math.isfinite(cmkf_upper[i]) else _fmt(cmkf_density[i]))
        lines.append(f"{axis:8} {_fmt(bias[i])} {_fmt(bias_std[i])} {_fmt(density[i])} {n_cmkf} "
                     f"{_fmt(cov[i])}   {unit}")
    if state.noise is not None:
        bank_cols = [c for c in state.noise[1] if c.startswith("bank_")]
        if bank_cols:
            lines.append("")
            lines.append("most probable hypothesis θ̂: " + "  ".join(c[5:] for c in bank_cols))
            for i, axis in enumerate(AXES):
                lines.append(f"{axis:8} " + " ".join(_fmt(column(state.noise, c)[i]) for c in bank_cols))
    lines.append("")
    if state.hypotheses is None:
        lines.append("hypotheses: waiting for stationary data")
    else:
        _, cols, rows = state.hypotheses
        names = [c for c in cols if c not in HYPOTHESES_EXTRA_COLUMNS]
        lines.append(f"{'axis':8} " + " ".join(f"P({n})".rjust(12) for n in names) + f" {'updates':>8}  decision")
        for axis, row in zip(AXES, rows, strict=False):
            probs = " ".join((f"{row[j]:12.3f}" if math.isfinite(row[j]) else "—".rjust(12))
                             for j in range(len(names)))
            k = int(row[cols.index("decision")])
            name = names[k] if 0 <= k < len(names) else None

            def value(col: str, row: list[float] = row) -> float:
                return float(row[cols.index(col)]) if col in cols else math.nan

            decision = decision_text(name, raw=row[k] if name else math.nan, held=value("decision_probability"),
                                     since=value("decision_time_s"), gamma=value("gamma"))
            lines.append(f"{axis:8} {probs} {int(row[cols.index('bank_updates')]):8d}  {decision}")
    lines.append("")
    lines.append("diagnostics:")
    if not state.diagnostics:
        lines.append("  (none received yet)")
    for name, (level, message) in sorted(state.diagnostics.items()):
        tag = LEVEL_NAMES.get(level, str(level))
        if colour:
            tag = f"{_COLOURS.get(level, '')}{tag}\x1b[0m"
        lines.append(f"  {tag:5} {name}: {message}")
    return "\n".join(lines)


class Listener:
    """Subscriptions filling a :class:`MonitorState` (created inside a running rclpy context)."""

    def __init__(self, node: object, name: str) -> None:
        from diagnostic_msgs.msg import DiagnosticArray
        from geometry_msgs.msg import Vector3Stamped
        from std_msgs.msg import Float64MultiArray

        self.state = MonitorState(node=name)
        self._prefix = name.lstrip("/") + ": "
        base = name.rstrip("/")
        node.create_subscription(Vector3Stamped, f"{base}/gyro_bias", self._gyro, 10)
        node.create_subscription(Vector3Stamped, f"{base}/accel_bias", self._accel, 10)
        node.create_subscription(Float64MultiArray, f"{base}/noise", self._noise, 10)
        node.create_subscription(Float64MultiArray, f"{base}/hypotheses", self._hyp, 10)
        node.create_subscription(DiagnosticArray, "/diagnostics", self._diag, 50)

    def _gyro(self, msg: object) -> None:
        self.state.gyro_bias = (msg.vector.x, msg.vector.y, msg.vector.z)
        self.state.stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9

    def _accel(self, msg: object) -> None:
        self.state.accel_bias = (msg.vector.x, msg.vector.y, msg.vector.z)

    def _noise(self, msg: object) -> None:
        from .messages import parse_labelled

        self.state.noise = parse_labelled(msg)

    def _hyp(self, msg: object) -> None:
        from .messages import parse_labelled

        self.state.hypotheses = parse_labelled(msg)

    def _diag(self, msg: object) -> None:
        for status in msg.status:
            if status.name.startswith(self._prefix):
                level = status.level[0] if isinstance(status.level, bytes) else int(status.level)
                self.state.diagnostics[status.name[len(self._prefix):]] = (level, status.message)


def run_monitor(node_name: str, *, once: bool = False, period: float = 0.5, timeout: float = 10.0,
                duration: float = 0.0) -> None:
    """Watch node ``node_name`` (fully qualified) until Ctrl-C or ``duration`` seconds (0: forever), or print one
    :func:`snapshot` with ``once``.

    Raises
    ------
    InputError
        With ``once``, when the node's outputs do not arrive within ``timeout`` seconds.
    """
    import rclpy

    rclpy.init()
    try:
        node = rclpy.create_node("imu_noise_id_monitor")
        listener = Listener(node, node_name)
        if once:
            snapshot(node, listener, timeout)
        else:
            watch(node, listener, period, duration)
    finally:
        if rclpy.ok():
            rclpy.shutdown()


def snapshot(node: object, listener: Listener, timeout: float) -> None:
    """Wait for the node's outputs (one more diagnostics period for every status) and print one screen."""
    import rclpy

    end = time.monotonic() + timeout
    while time.monotonic() < end and not listener.state.complete():
        rclpy.spin_once(node, timeout_sec=0.1)
    # One more diagnostics period so that every status of the node is in the snapshot.
    settle = time.monotonic() + 1.2
    while listener.state.complete() and time.monotonic() < settle:
        rclpy.spin_once(node, timeout_sec=0.1)
    if not listener.state.complete():
        raise InputError(silence_message(listener.state, timeout))
    print(render(listener.state))


def silence_message(state: MonitorState, timeout: float) -> str:
    """Why a snapshot has no outputs: the node is not heard, or is heard but has accepted no IMU message yet."""
    if not state.diagnostics:
        return (f"no outputs from node {state.node} within {timeout:g} s: is it running (and with "
                "ROS_AUTOMATIC_DISCOVERY_RANGE/ROS_DOMAIN_ID like this shell)?")
    imu = state.diagnostics.get("IMU input")
    status = f" (its IMU input status: {imu[1]})" if imu else ""
    return (f"node {state.node} is running but published no estimates within {timeout:g} s: it has accepted no "
            f"IMU message yet{status}. Publish on its IMU input (imu/data in its namespace, /imu/data by default; "
            "e.g. `imu-noise-id play BAG`) or remap the input to your IMU topic: -r imu/data:=TOPIC")


def watch(node: object, listener: Listener, period: float, duration: float, stream: object = None) -> None:
    """Redraw the view every ``period`` seconds for ``duration`` seconds (0: forever)."""
    import rclpy

    out = stream or sys.stdout
    tty = hasattr(out, "isatty") and out.isatty()
    start = time.monotonic()
    next_draw = start
    while rclpy.ok() and (duration == 0 or time.monotonic() - start < duration):
        rclpy.spin_once(node, timeout_sec=0.05)
        now = time.monotonic()
        if now >= next_draw:
            next_draw = now + period
            text = render(listener.state, colour=tty)
            if tty:
                out.write("\x1b[H\x1b[J" + text + "\n")
            else:
                out.write(text + "\n" + "-" * 60 + "\n")
            out.flush()
