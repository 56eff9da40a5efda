"""The CUSUMs of :mod:`.noise_level` sample by sample (the node's watch): each pair's difference moves both CUSUMs
of every axis; an alarm keeps its time and where the change began. Live ratio: √ of the exponentially weighted mean
of d²/v_ref over ``window`` seconds."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .noise_level import LevelAlarm, directions, threshold

#: Time constant [s] of the live ratio's average.
DEFAULT_WINDOW_S = 60.0


@dataclass(frozen=True)
class AxisWatch:
    """One axis now: the live/reference density ratio (NaN before a pair), pairs seen and the first alarm (or None)."""

    ratio: float
    pairs: int
    alarm: LevelAlarm | None


class SequentialNoiseWatch:
    """Both CUSUMs per axis against references of E[(y_{t+1} − y_t)²] ``v_ref`` (k,) [u²] and their intervals
    ``intervals`` ((lo, hi) per axis), for samples at period ``period`` [s]; ``ratio`` and ``false_alarms_per_hour``
    as in :func:`~.noise_level.watch_noise_level`."""

    def __init__(self, v_ref: np.ndarray, intervals: list[tuple[float, float]], period: float, *, ratio: float,
                 false_alarms_per_hour: float, window_s: float = DEFAULT_WINDOW_S) -> None:
        self.v_ref = np.asarray(v_ref, dtype=float)
        k = self.v_ref.size
        self.h = threshold(false_alarms_per_hour, 0.5 / period)
        self.a = np.full((k, 2), -np.inf)
        self.b = np.zeros((k, 2))
        self.cap = np.full((k, 2), np.inf)
        for i in range(k):
            for direction, a, b, cap in directions(float(self.v_ref[i]), intervals[i], ratio):
                j = 0 if direction == "up" else 1
                self.a[i, j], self.b[i, j], self.cap[i, j] = a, b, cap
        self.s = np.zeros((k, 2))
        self.left_zero = np.full((k, 2), math.nan)
        self.alarms: list[LevelAlarm | None] = [None] * k
        self.window_s = window_s
        self.mean_ratio2 = np.full(k, math.nan)
        self.pairs = 0
        self._pending: tuple[float, np.ndarray] | None = None

    def add(self, t: float, sample: np.ndarray) -> None:
        """A stationary sample at stamp ``t`` [s]: the second of a pair moves the CUSUMs."""
        if self._pending is None:
            self._pending = (t, np.asarray(sample, dtype=float))
            return
        t0, first = self._pending
        self._pending = None
        d2 = (np.asarray(sample, dtype=float) - first) ** 2
        s = np.maximum(self.s + self.a + self.b * np.minimum(d2[:, None], self.cap), 0.0)
        leaving = (self.s == 0.0) & (s > 0.0)
        self.left_zero[leaving] = t0
        self.s = s
        for i, j in zip(*np.nonzero(s > self.h), strict=True):
            if self.alarms[i] is None:
                self.alarms[i] = LevelAlarm("up" if j == 0 else "down", float(t), float(self.left_zero[i, j]))
        weight = 1.0 - math.exp(-2.0 * max(t - t0, 0.0) / self.window_s) if self.pairs else 1.0
        current = d2 / self.v_ref
        self.mean_ratio2 = np.where(np.isnan(self.mean_ratio2), current,
                                    self.mean_ratio2 + weight * (current - self.mean_ratio2))
        self.pairs += 1

    def break_chain(self) -> None:
        """Motion or a gap: no pair across it."""
        self._pending = None

    def axis(self, i: int) -> AxisWatch:
        return AxisWatch(math.sqrt(self.mean_ratio2[i]) if self.pairs else math.nan, self.pairs, self.alarms[i])
