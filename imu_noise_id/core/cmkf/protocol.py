"""The robot CMKF's accelerometer filter interface (filterpy's names): ``AxisCmkf``, ``VelocityAxisCmkf``."""

from __future__ import annotations

from typing import Protocol

import numpy as np

from .interval import ImuInterval
from .matching import MatchingLeastSquares


class CmkfFilter(Protocol):
    """Paper 004's CMKF for ``n`` axes: propagation (17), (23), Joseph update (24)–(27), S_v estimate (28)–(35).
    ``m``: measurement components per axis (1: velocity, 2: position and velocity); ``x``, ``P``: (n, 3) state
    ``[r, v, b]`` and (n, 3, 3) covariance (r carried and NaN in P where not estimated); ``y``, ``S``: innovations
    (n, m) and covariances (n, m, m) of the last update; ``S_used``, ``S_ls``: (n,) Ŝ_v in use and the least-squares
    one [m²/s³] of ``matching``; ``count``, ``rejected``, ``skipped``, ``skipped_stacked``: stacked samples, estimates
    refused, updates and stacked steps skipped."""

    n: int
    m: int
    initialised: bool
    matching: MatchingLeastSquares
    count: int
    rejected: int
    skipped: int
    skipped_stacked: int

    @property
    def x(self) -> np.ndarray: ...

    @property
    def P(self) -> np.ndarray: ...

    @property
    def y(self) -> np.ndarray: ...

    @property
    def S(self) -> np.ndarray: ...

    @property
    def S_used(self) -> np.ndarray: ...

    @property
    def S_ls(self) -> np.ndarray: ...

    def initialise(self, x0: np.ndarray, P0: np.ndarray) -> None:
        """Set x̂₀ (n, 3) and P₀ (n, 3, 3); starts a new chain for the stacked estimator."""

    def predict(self, x_pred: np.ndarray, interval: ImuInterval) -> None:
        """Covariance over ``interval`` (eq. 23) to the already propagated ``x_pred`` (n, 3); one call per epoch."""

    def predicted_P(self, interval: ImuInterval) -> np.ndarray:
        """P⁻ after ``interval`` without changing the filter (for reporting between updates)."""

    def nis(self, z: np.ndarray, R: np.ndarray) -> np.ndarray:
        """NIS per axis that :meth:`update` would have now, without updating (for :mod:`.gate`)."""

    def update(self, z: np.ndarray, R: np.ndarray, new_chain: bool = False) -> np.ndarray:
        """Joseph update (24)–(27), ``z`` (n, m), ``R`` (n, m, m), a stacked step unless ``new_chain``; NIS (n,)/NaN."""
