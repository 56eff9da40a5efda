"""χ² acceptance bounds of the normalised innovation squared (NIS): the one consistency bound of the package.

For a consistent Kalman filter the NIS ``νᵀS⁻¹ν`` of an update with ``dof`` measurement components is χ²(dof)
(paper 004 and the online node check their filters this way), and the sum of ``n`` independent NIS values is
χ²(n·dof). :func:`nis_bounds` gives the two-sided acceptance interval of their mean. It is used by the online
node's ``Filter consistency`` status, :class:`~.monitor.InnovationMonitor`, the CMKF replay's ``nis`` summary
(:func:`imu_noise_id.pipelines.cmkf_replay.nis_summary`) and the NIS panel of ``cmkf.png``. :func:`nis_gate` is the
CMKF's innovation gate (:mod:`imu_noise_id.core.cmkf.gate`) and :func:`nis_verdict` the consistency verdict the
CMKF reports (its estimate's ``consistency``, the replay's summary, the node's diagnostics).
"""

from __future__ import annotations

import math
from functools import lru_cache

from scipy.stats import chi2


@lru_cache(maxsize=1024)
def nis_bounds(dof: int, n: int = 1, alpha: float = 0.05) -> tuple[float, float]:
    """Two-sided ``1 − alpha`` acceptance interval of the mean of ``n`` independent NIS values of ``dof`` each.

    Parameters
    ----------
    dof : int
        Degrees of freedom of one NIS value (the measurement dimension), ≥ 1.
    n : int
        Number of NIS values averaged, ≥ 1 (1: the bounds of a single value).
    alpha : float
        Total probability outside the interval, in (0, 1) (0.05: the 95 % bounds).

    Returns
    -------
    tuple of float
        ``(χ²_{α/2}(n·dof) / n, χ²_{1−α/2}(n·dof) / n)``.

    Raises
    ------
    ValueError
        If ``dof`` or ``n`` is below 1 or ``alpha`` is not in (0, 1).
    """
    if dof < 1 or n < 1:
        raise ValueError(f"dof and n must be >= 1, got dof={dof}, n={n}")
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    k = n * dof
    return float(chi2.ppf(alpha / 2, k) / n), float(chi2.ppf(1.0 - alpha / 2, k) / n)


def nis_gate(dof: int, probability: float) -> float:
    """Innovation gate: the NIS above which one update of ``dof`` components is rejected as an outlier.

    The ``1 − probability`` quantile of χ²(dof): a consistent filter rejects a good update with that
    ``probability`` (1e-6 and 3 dof: 30.7, about one false rejection in 28 h at 10 Hz). ``probability = 0``
    disables the gate (returns ``inf``).

    Raises
    ------
    ValueError
        If ``dof`` is below 1 or ``probability`` is not in [0, 0.5).
    """
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
    """Consistency of a filter from the mean of ``n`` NIS values of ``dof`` each and the share of gated updates.

    Returns ``"unknown"`` (fewer than 10 values), ``"inconsistent"`` (mean beyond :data:`INCONSISTENT_FACTOR` × dof
    either way, or more than :data:`INCONSISTENT_GATED_SHARE` of the updates gated), ``"marginal"`` (outside the
    95 % bounds of :func:`nis_bounds`) or ``"consistent"``.
    """
    if gated_share > INCONSISTENT_GATED_SHARE:
        return "inconsistent"
    if n < 10 or not math.isfinite(mean):
        return "unknown"
    if mean > INCONSISTENT_FACTOR * dof or mean < dof / INCONSISTENT_FACTOR:
        return "inconsistent"
    low, high = nis_bounds(dof, n)
    return "consistent" if low <= mean <= high else "marginal"
