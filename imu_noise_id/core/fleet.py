"""Fleet statistics: robust outliers among units and pass/fail against a datasheet specification.

Outliers: the modified z-score of Iglewicz & Hoaglin (1993), z = 0.6745·(x − median)/MAD, computed on log values
(noise figures are positive and spread multiplicatively); |z| > 3.5 flags a unit. With fewer than
:data:`MIN_UNITS` units, or a MAD of 0, nothing is flagged (the spread cannot be judged).

Specification: the largest allowed value of a parameter per sensor, e.g. ``{"gyro": {"noise_density": 3e-4}}``; a
unit passes when the upper end of its 95 % interval is below it (the margin spec/value − 1 is reported beside), and
is "undecided" when the value is below but the interval reaches above.
"""

from __future__ import annotations

import math

import numpy as np

#: Flag a unit whose |modified z| exceeds this (Iglewicz & Hoaglin).
OUTLIER_Z = 3.5
#: Fewest units whose spread is judged.
MIN_UNITS = 5


def modified_z(values: np.ndarray) -> np.ndarray:
    """Modified z-scores of positive values on a log scale (NaN where a value is missing or not positive)."""
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


def spec_verdict(value: float | None, ci_high: float | None, limit: float) -> tuple[str, float]:
    """(``pass`` | ``fail`` | ``undecided`` | ``missing``, margin spec/value − 1) of one value against its limit."""
    if value is None or not math.isfinite(value) or value <= 0:
        return "missing", math.nan
    margin = limit / value - 1.0
    if value > limit:
        return "fail", margin
    if ci_high is not None and math.isfinite(ci_high) and ci_high > limit:
        return "undecided", margin
    return "pass", margin
