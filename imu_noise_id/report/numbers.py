"""How numbers are written into the YAML outputs (one rule for every file)."""

from __future__ import annotations

import math

#: Significant digits of the numbers in imu.yaml and model.yaml.
DIGITS = 6


def num(x: float) -> float:
    """A plain float with :data:`DIGITS` significant digits (inf and NaN kept; YAML writes them as .inf/.nan)."""
    x = float(x)
    return x if not math.isfinite(x) else float(f"{x:.{DIGITS}g}")


#: Keys written at full precision (log-likelihoods and criteria built from them; why: docs/em.md).
FULL_PRECISION = frozenset({"loglik", "aic", "bic", "delta_bic", "delta_aic"})


def num_key(key: str, x: float) -> float:
    """:func:`num`, except for the :data:`FULL_PRECISION` keys (written as the float they are)."""
    return float(x) if key in FULL_PRECISION else num(x)


def interval(ci: tuple[float, float]) -> list[float] | None:
    """A 95 % interval as ``[lo, hi]`` (:func:`num`), or None (YAML ``null``) for a reading without one (NaN)."""
    if any(math.isnan(float(v)) for v in ci):
        return None
    return [num(ci[0]), num(ci[1])]
