"""Finite differences that stay inside the components' domains (one-sided where a step raises ValueError)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def derivative_in_domain(
    shifted: Callable[[float], np.ndarray | float], step: float, at_zero: Callable[[], np.ndarray | float], *,
    central: bool = True,
) -> np.ndarray | None:
    """d/dh of ``shifted(h)`` at 0 by a central (``central=False``: forward) difference of ``step``; one-sided
    against ``at_zero()`` where a step raises ValueError; None when both do."""
    values = {}
    for h in (step, -step):
        if values and not central:  # the forward step stayed inside
            break
        try:
            values[h] = np.asarray(shifted(h), dtype=float)
        except ValueError:  # the step left a component's domain
            continue
    if len(values) == 2:
        return (values[step] - values[-step]) / (2.0 * step)
    if not values:
        return None
    (h, value), = values.items()
    return (value - np.asarray(at_zero(), dtype=float)) / h


def stepped(theta: np.ndarray, k: int, h: float) -> np.ndarray:
    """A copy of ``theta`` with entry ``k`` moved by ``h``."""
    out = np.array(theta, dtype=float)
    out[k] += h
    return out
