"""How numbers are written into the YAML outputs (one rule for every file)."""

from __future__ import annotations

import math

#: Significant digits of the numbers in imu.yaml and model.yaml.
DIGITS = 6


def num(x: float) -> float:
    """A plain float with :data:`DIGITS` significant digits (inf and NaN kept; YAML writes them as .inf/.nan)."""
    x = float(x)
    return x if not math.isfinite(x) else float(f"{x:.{DIGITS}g}")
