"""χ² acceptance bounds of the normalised innovation squared (NIS): the one consistency bound of the package.

For a consistent Kalman filter the NIS ``νᵀS⁻¹ν`` of an update with ``dof`` measurement components is χ²(dof)
(paper 004 and the online node check their filters this way), and the sum of ``n`` independent NIS values is
χ²(n·dof). :func:`nis_bounds` gives the two-sided acceptance interval of their mean. It is used by the online
node's ``Filter consistency`` status, :class:`~.monitor.InnovationMonitor`, the CMKF replay's ``nis`` summary
(:func:`imu_noise_id.pipelines.cmkf_replay.nis_summary`) and the NIS panel of ``cmkf.png``.
"""

from __future__ import annotations

from scipy.stats import chi2


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
