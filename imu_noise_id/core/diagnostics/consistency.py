"""χ² bounds of the normalised innovation squared νᵀS⁻¹ν, χ²(dof) per update of a consistent filter."""

from __future__ import annotations

import math
from functools import lru_cache

from scipy.stats import chi2


@lru_cache(maxsize=1024)
def nis_bounds(dof: int, n: int = 1, alpha: float = 0.05) -> tuple[float, float]:
    """``1 − alpha`` interval (χ²_{α/2}(n·dof)/n, χ²_{1−α/2}(n·dof)/n) of the mean of ``n`` NIS of ``dof`` each;
    ValueError on bad arguments."""
    if dof < 1 or n < 1:
        raise ValueError(f"dof and n must be >= 1, got dof={dof}, n={n}")
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    k = n * dof
    return float(chi2.ppf(alpha / 2, k) / n), float(chi2.ppf(1.0 - alpha / 2, k) / n)


def nis_gate(dof: int, probability: float) -> float:
    """NIS rejecting one update of ``dof`` components: χ²(dof)'s ``1 − probability`` quantile (0: inf); ValueError on
    bad arguments."""
    if dof < 1:
        raise ValueError(f"dof must be >= 1, got {dof}")
    if not 0.0 <= probability < 0.5:
        raise ValueError(f"the gate probability must be in [0, 0.5), got {probability}")
    return float(chi2.isf(probability, dof)) if probability > 0 else math.inf


#: Mean NIS beyond this factor of its degrees of freedom (either way), or more than this share of updates rejected
#: by the innovation gate, makes a filter inconsistent rather than marginal.
INCONSISTENT_FACTOR = 3.0
INCONSISTENT_GATED_SHARE = 0.25


def nis_verdict(mean: float, dof: int, n: int, gated_share: float = 0.0) -> str:
    """``"unknown"`` (n < 10), ``"inconsistent"`` (mean beyond :data:`INCONSISTENT_FACTOR` × dof either way, or more
    than :data:`INCONSISTENT_GATED_SHARE` gated), ``"marginal"`` (outside the 95 % bounds) or ``"consistent"``."""
    if gated_share > INCONSISTENT_GATED_SHARE:
        return "inconsistent"
    if n < 10 or not math.isfinite(mean):
        return "unknown"
    if mean > INCONSISTENT_FACTOR * dof or mean < dof / INCONSISTENT_FACTOR:
        return "inconsistent"
    low, high = nis_bounds(dof, n)
    return "consistent" if low <= mean <= high else "marginal"
