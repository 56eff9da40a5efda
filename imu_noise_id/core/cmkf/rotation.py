"""Small quaternion helpers (Hamilton convention, ``[x, y, z, w]`` as in ROS), plain floats for speed."""

from __future__ import annotations

import math

import numpy as np

Quat = tuple[float, float, float, float]
IDENTITY: Quat = (0.0, 0.0, 0.0, 1.0)


def normalise(q: np.ndarray | tuple[float, ...] | list[float]) -> Quat:
    """Unit quaternion ``(x, y, z, w)``; raises ValueError on a zero or non-finite input."""
    x, y, z, w = (float(c) for c in q)
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if not math.isfinite(n) or n < 1e-9:
        raise ValueError(f"not a valid quaternion: {q!r}")
    return (x / n, y / n, z / n, w / n)


def multiply(a: Quat, b: Quat) -> Quat:
    """Hamilton product ``a ⊗ b`` (rotation b then a, for frame chaining ``q_nb ⊗ q_bi = q_ni``)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def conjugate(q: Quat) -> Quat:
    """Inverse rotation of a unit quaternion."""
    return (-q[0], -q[1], -q[2], q[3])


def to_matrix(q: Quat) -> np.ndarray:
    """Rotation matrix ``C`` with ``v_parent = C v_child`` for ``q`` = orientation of child in parent."""
    x, y, z, w = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def to_rotvec(q: Quat) -> np.ndarray:
    """Rotation vector [rad] of a unit quaternion (angle in [0, π])."""
    x, y, z, w = q
    if w < 0:
        x, y, z, w = -x, -y, -z, -w
    s = math.sqrt(x * x + y * y + z * z)
    if s < 1e-12:
        return np.array([2 * x, 2 * y, 2 * z])
    angle = 2.0 * math.atan2(s, w)
    return np.array([x, y, z]) * (angle / s)


def from_ypr(yaw: float, pitch: float, roll: float) -> Quat:
    """Quaternion of ``Rz(yaw) Ry(pitch) Rx(roll)`` (``static_transform_publisher x y z yaw pitch roll``'s order)."""
    qz = (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
    qy = (0.0, math.sin(pitch / 2), 0.0, math.cos(pitch / 2))
    qx = (math.sin(roll / 2), 0.0, 0.0, math.cos(roll / 2))
    return multiply(multiply(qz, qy), qx)
