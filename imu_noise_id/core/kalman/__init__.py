"""Kalman filter and smoother of :class:`~.statespace.StateSpace` models: exact or steady-state (``engine``)."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from . import exact, steady
from .common import (
    Columns,
    InnovationResult,
    ProfileResult,
    SmootherStats,
    StateSums,
    apply_beta,
    build_columns,
    check_data,
    profile,
)
from .statespace import StateSpace

__all__ = [
    "Columns", "InnovationResult", "ProfileResult", "SmootherStats", "StateSums", "apply_beta", "loglik",
    "profile_and_smooth", "smooth",
]

ENGINES = ("auto", "steady", "exact")


def _engine(model: StateSpace, y: np.ndarray, engine: str):
    if engine not in ENGINES:
        raise InputError(f"engine must be one of {', '.join(ENGINES)}, got {engine!r}")
    can_steady = model.sigma_mode == "steady" and not np.any(np.isnan(y))
    if engine == "steady" and not can_steady:
        raise InputError("the steady engine needs sigma_mode='steady' and no missing samples")
    return steady if (engine == "steady" or (engine == "auto" and can_steady)) else exact


def loglik(
    model: StateSpace, y: np.ndarray, z: np.ndarray | None = None, *, profile_mean: bool = True,
    engine: str = "auto", innovations: bool = True,
) -> ProfileResult:
    """Exact log-likelihood of y (NaN: missing); ``profile_mean``: free b, u, μ at their GLS estimate;
    ``innovations``: keep the innovations at the estimate (else the result's are empty: one pass less)."""
    y, z = check_data(y, z, model.n_regressors)
    cols = build_columns(model, y, z, profile_mean)
    inn = _engine(model, y, engine).innovations(model, cols)
    return profile(inn, cols.names, keep_innovations=innovations)


def profile_and_smooth(
    model: StateSpace, y: np.ndarray, z: np.ndarray | None = None, *, engine: str = "auto", moments: bool = True,
) -> tuple[ProfileResult, StateSpace, SmootherStats]:
    """:func:`loglik` with the mean parameters profiled, the model at their estimate, and its E-step statistics
    (``moments``: with the p × p sums of the smoothed means the M-step needs and the score does not)."""
    y, z = check_data(y, z, model.n_regressors)
    cols = build_columns(model, y, z, True)
    eng = _engine(model, y, engine)
    if eng is steady:
        prof, stats = steady.profile_and_smooth(model, cols, y, z, moments=moments)
        return prof, apply_beta(model, prof), stats
    prof = profile(eng.innovations(model, cols), cols.names)
    fitted = apply_beta(model, prof)
    return prof, fitted, eng.smooth(fitted, build_columns(fitted, y, z, False), y, z, moments=moments)


def smooth(model: StateSpace, y: np.ndarray, z: np.ndarray | None = None, *, engine: str = "auto") -> SmootherStats:
    """E-step: the sums of the smoothed means and covariances the M-step needs, at the model's current parameters."""
    y, z = check_data(y, z, model.n_regressors)
    cols = build_columns(model, y, z, profile=False)
    return _engine(model, y, engine).smooth(model, cols, y, z)
