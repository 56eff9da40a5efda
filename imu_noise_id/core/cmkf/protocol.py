"""What the robot CMKF needs from an accelerometer filter: one interface for the exact and the fast filter.

Both :class:`~.axis.AxisCmkf` (batched numpy, any measurement) and :class:`~.fast_vel.VelocityAxisCmkf` (plain
floats, velocity measurements: the node's hot path) implement paper 004's filter for ``n`` independent axes with
state ``[r, v, b]`` per axis, and :class:`~.robot.RobotCmkf` uses either through this interface (the naming of
filterpy: ``predict`` / ``update(z, R)``, state ``x``, covariance ``P``, innovation ``y`` and its covariance ``S``).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from .interval import ImuInterval
from .matching import MatchingLeastSquares


class CmkfFilter(Protocol):
    """Paper 004's CMKF for ``n`` axes: propagation (17), (23), Joseph update (24)–(27), S_v estimate (28)–(35).

    Attributes
    ----------
    n : number of axes; m : measurement components per axis (1: velocity, 2: position and velocity).
    initialised : whether :meth:`initialise` was called.
    x : (n, 3) state ``[r, v, b]`` per axis (a filter that does not estimate ``r`` carries the value it was given).
    P : (n, 3, 3) its covariance (NaN in the ``r`` row and column of a filter that does not estimate ``r``).
    y, S : innovations (n, m) and their covariances (n, m, m) of the last update.
    S_used : (n,) Ŝ_v in use [m²/s³]; S_ls : (n,) latest least-squares Ŝ_v (NaN before the first stacked sample).
    matching : the least squares behind ``S_ls``, with its standard error (:mod:`.matching`);
    count : stacked samples in the estimate; rejected : estimates refused by the positive-definiteness check;
    skipped : updates skipped (innovation covariance not positive definite); skipped_stacked : stacked steps
    skipped (degenerate interval).
    """

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
        """Covariance over ``interval`` (eq. 23) to the already propagated state ``x_pred`` (n, 3).

        The known input of the interval is ``U = x_pred − F̂ x̂⁺`` (eq. 17); one call per measurement epoch.
        """

    def predicted_P(self, interval: ImuInterval) -> np.ndarray:
        """P⁻ after ``interval`` without changing the filter (for reporting between updates)."""

    def nis(self, z: np.ndarray, R: np.ndarray) -> np.ndarray:
        """NIS per axis that :meth:`update` with ``z`` and ``R`` would have now, without updating (for the
        innovation gate, :mod:`.gate`)."""

    def update(self, z: np.ndarray, R: np.ndarray, new_chain: bool = False) -> np.ndarray:
        """Joseph update (24)–(27) with ``z`` (n, m) and ``R`` (n, m, m), then one stacked-estimator step (none
        across a gap: ``new_chain``); returns the NIS per axis (NaN when the update had to be skipped)."""
