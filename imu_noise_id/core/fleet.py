"""Fleet statistics: modified z-scores (Iglewicz & Hoaglin 1993) and pass/fail against a specification's limits."""

from __future__ import annotations

import math

import numpy as np

#: Flag a unit whose |modified z| exceeds this (Iglewicz & Hoaglin).
OUTLIER_Z = 3.5
#: Fewest units whose spread is judged.
MIN_UNITS = 5


def modified_z(values: np.ndarray) -> np.ndarray:
    """z = 0.6745·(x − median)/MAD of log values (NaN: missing or ≤ 0; all NaN below :data:`MIN_UNITS` or at MAD 0)."""
    v = np.asarray(values, dtype=float)
    out = np.full(v.shape, np.nan)
    ok = np.isfinite(v) & (v > 0)
    if ok.sum() < MIN_UNITS:
        return out
    logs = np.log(v[ok])
    med = float(np.median(logs))
    mad = float(np.median(np.abs(logs - med)))
    if mad <= 0:
        return out
    out[ok] = 0.6745 * (logs - med) / mad
    return out


def spec_verdict(value: float | None, ci_high: float | None, limit: float, *, bound: bool = False) -> tuple[str, float]:
    """(``pass`` (``ci_high`` below ``limit``), ``undecided`` (only the value below, or ``value`` an upper ``bound``
    above the limit: the record cannot tell), ``fail`` or ``missing``; margin limit/value − 1)."""
    if value is None or not math.isfinite(value) or value <= 0:
        return "missing", math.nan
    margin = limit / value - 1.0
    if value > limit:
        return ("undecided" if bound else "fail"), margin
    if ci_high is not None and math.isfinite(ci_high) and ci_high > limit:
        return "undecided", margin
    return "pass", margin
