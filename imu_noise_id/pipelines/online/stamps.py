"""Header-stamp checks of one input stream against its own history (:class:`StampChecker`; docs/node.md): **rate**,
trimmed mean of the mean intervals of :data:`SUBWINDOWS` blocks of :data:`SUBWINDOW` messages, known after
:data:`LEARN`; **gap**, an interval > ``gap_factor`` × the period: held until the next stamp confirms it (``gap``)
or returns (``outlier``), :data:`RELEARN_COUNT` equal gaps a new rate (``relearn``); **backward**, rejected, but
``backward_reset_count`` in a row at the stream's rate are a ``restart``; ``duplicate``, ``bad_stamp`` rejected."""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

#: Accepted messages per block of the period estimate, and blocks kept (the trimmed mean of their mean intervals).
SUBWINDOW = 50
SUBWINDOWS = 9
#: Intervals needed before the period is known (and a stamp can be a gap).
LEARN = 10
#: Consecutive gaps of nearly equal length (within a factor :data:`RELEARN_SPREAD`) that set a new period.
RELEARN_COUNT = 10
RELEARN_SPREAD = 2.0
#: Verdicts of :meth:`StampChecker.check`: for the message (``hold``: wait for the next message) and for a held one.
VERDICTS = ("ok", "gap", "relearn", "restart", "hold", "outlier", "bad_stamp", "duplicate", "backward")


@dataclass
class StampChecker:
    """Header-stamp checks for one input stream (module docstring). :meth:`check` returns ``(verdict, held)``: this
    stamp's ``ok``, ``relearn``, ``restart``, ``hold``, ``bad_stamp``, ``duplicate`` or ``backward``, and the held
    stamp's ``gap``, ``relearn`` (process it first) or ``outlier``; ``counts`` counts every verdict."""

    gap_factor: float = 10.0
    backward_reset_count: int = 10
    last: float | None = None
    held: float | None = None
    period: float | None = None
    counts: dict[str, int] = field(default_factory=lambda: dict.fromkeys(VERDICTS, 0))
    _block: list[float] = field(default_factory=list)
    _means: deque[float] = field(default_factory=lambda: deque(maxlen=SUBWINDOWS))
    _gap_run: list[float] = field(default_factory=list)
    _backward: list[float] = field(default_factory=list)

    @property
    def rate(self) -> float:
        """Nominal rate from the header stamps [Hz] (NaN until it is learnt)."""
        return 1.0 / self.period if self.period else math.nan

    def check(self, t: float) -> tuple[str, str | None]:
        """The verdicts of stamp ``t`` [s] and of the stamp held before it (see the class docstring)."""
        verdict, held = self._judge(t)
        self.counts[verdict] += 1
        if held is not None:
            self.counts[held] += 1
        return verdict, held

    def _judge(self, t: float) -> tuple[str, str | None]:
        if not math.isfinite(t) or t <= 0.0:
            return "bad_stamp", None
        held_verdict = None
        held = self.held
        if held is not None:
            if t == held:
                return "duplicate", None
            if t > held:  # the time line goes on after the jump: it was real
                self.held = None
                held_verdict = self._gap(held)
            elif self.last is not None and t > self.last:  # back on the old time line: the jump was an outlier
                self.held = None
                held_verdict = "outlier"
            else:
                return self._behind(t), None
        return self._next(t), held_verdict

    def _next(self, t: float) -> str:
        """Judge ``t`` against the last accepted stamp."""
        last = self.last
        if last is None:
            self._accept(t)
            return "ok"
        dt = t - last
        if dt == 0.0:
            return "duplicate"
        if dt < 0.0:
            return self._behind(t)
        self._backward.clear()
        if self.period is not None and dt > self.gap_factor * self.period:
            run = [*self._gap_run, dt][-RELEARN_COUNT:]
            if len(run) == RELEARN_COUNT and max(run) <= RELEARN_SPREAD * min(run):
                return self._gap(t)  # the tenth equal gap: a new rate, no need to wait
            self.held = t
            return "hold"
        self._gap_run.clear()
        self._accept(t)
        return "ok"

    def _gap(self, t: float) -> str:
        """Accept ``t`` after a confirmed jump; ``relearn`` when it completes a run of equal gaps."""
        dt = t - self.last
        self._gap_run.append(dt)
        run = self._gap_run[-RELEARN_COUNT:]
        if len(run) == RELEARN_COUNT and max(run) <= RELEARN_SPREAD * min(run):
            self._gap_run.clear()
            self._restart_history(float(sorted(run)[len(run) // 2]))
            self._accept(t)
            return "relearn"
        self._accept(t)
        return "gap"

    def _behind(self, t: float) -> str:
        """A stamp behind the last accepted one: ``backward``, or ``restart`` when enough of them in a row follow
        one another at about the stream's rate."""
        chain = self._backward
        limit = self.gap_factor * (self.period or math.inf)
        if chain and not 0.0 < t - chain[-1] <= limit:
            chain.clear()
        chain.append(t)
        if len(chain) < self.backward_reset_count:
            return "backward"
        chain.clear()
        self.held = None
        self.last = None
        self._restart_history(self.period)
        self._accept(t)
        return "restart"

    def _restart_history(self, period: float | None) -> None:
        self.period = period
        self._block.clear()
        self._means.clear()

    def _accept(self, t: float) -> None:
        """``t`` is the new last stamp; its interval counts towards the period (a gap too)."""
        block = self._block
        block.append(t)
        self.last = t
        if len(block) > SUBWINDOW:
            self._means.append((block[-1] - block[0]) / (len(block) - 1))
            del block[:-1]
            means = sorted(self._means)
            # the trimmed mean (the shortest and the longest block dropped: a gap, or a block that caught fewer of a
            # bursty driver's pauses than its neighbours); with one or two blocks the shorter
            self.period = sum(means[1:-1]) / (len(means) - 2) if len(means) >= 3 else means[0]
        elif not self._means and self.period is None and len(block) > LEARN:
            self.period = (block[-1] - block[0]) / (len(block) - 1)
