"""Innovation gate of the robot CMKF's filters (χ², :data:`GATE_PATIENCE`) and the NIS window of its consistency
verdict (beyond paper 004; docs/cmkf.md, "Innovation gate")."""

from __future__ import annotations

import math
from collections import deque

from ..diagnostics.consistency import nis_gate, nis_verdict

#: Consecutive rejected updates after which the next one is accepted whatever its NIS.
GATE_PATIENCE = 3


class InnovationGate:
    """χ² gate on the NIS of one filter's updates (``dof`` summed over the axes, tail ``probability``; 0: never
    reject); attributes ``threshold``, ``rejected``, ``in_a_row``, ``largest`` (largest NIS rejected)."""

    def __init__(self, dof: int, probability: float) -> None:
        self.threshold = nis_gate(dof, probability)
        self.rejected = 0
        self.in_a_row = 0
        self.largest = 0.0

    def rejects(self, nis: float) -> bool:
        """Whether the update with this NIS is rejected (counted); a NaN NIS is not (the filter skips it)."""
        if not (nis > self.threshold) or self.in_a_row >= GATE_PATIENCE:
            self.in_a_row = 0
            return False
        self.in_a_row += 1
        self.rejected += 1
        if math.isfinite(nis):
            self.largest = max(self.largest, nis)
        return True


class NisWindow:
    """The last ``size`` updates (None: every one) of one filter (``dof`` each): the accepted ones' NIS, the gated."""

    def __init__(self, dof: int, size: int | None) -> None:
        self.dof = int(dof)
        self._nis: deque[float] = deque(maxlen=size)
        self._gated: deque[bool] = deque(maxlen=size)
        self._sum = 0.0

    def add(self, nis: float, gated: bool) -> None:
        """One update's NIS (a gated one counts only as gated)."""
        self._gated.append(gated)
        if gated or not math.isfinite(nis):
            return
        if len(self._nis) == self._nis.maxlen:
            self._sum -= self._nis[0]
        self._nis.append(nis)
        self._sum += nis

    @property
    def n(self) -> int:
        """Accepted updates in the window."""
        return len(self._nis)

    @property
    def updates(self) -> int:
        """Updates in the window, gated ones included."""
        return len(self._gated)

    @property
    def gated(self) -> int:
        """Gated updates in the window."""
        return sum(self._gated)

    @property
    def mean(self) -> float:
        """Mean NIS of the accepted updates in the window (NaN when none)."""
        return self._sum / len(self._nis) if self._nis else math.nan

    @property
    def gated_share(self) -> float:
        """Share of the window's updates rejected by the gate."""
        return self.gated / len(self._gated) if self._gated else 0.0

    def verdict(self) -> str:
        """:func:`~imu_noise_id.core.diagnostics.consistency.nis_verdict` of the window."""
        return nis_verdict(self.mean, self.dof, self.n, self.gated_share)
