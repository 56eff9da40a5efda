"""The CUSUMs of :mod:`.noise_level` sample by sample (the node's watch): an alarm confirmed by the level of the next
``confirm_pairs`` pairs, else a transient and the CUSUMs restart; live ratio over ``window`` s."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .noise_level import LevelAlarm, NoiseLevel, directions, ratio_interval, threshold

#: Time constant [s] of the live ratio's average.
DEFAULT_WINDOW_S = 60.0
#: Pairs after an alarm whose level confirms it or finds it a transient (a knock's burst is a small part of them),
#: by default.
CONFIRM_MIN_PAIRS = 1000


@dataclass(frozen=True)
class AxisWatch:
    """One axis now: ``ratio`` (NaN before a pair), ``pairs``, ``alarm``, ``confirmed_s`` [s], ``since_ratio``,
    ``transient``."""

    ratio: float
    pairs: int
    alarm: LevelAlarm | None
    confirmed_s: float | None = None
    since_ratio: float = math.nan
    transient: LevelAlarm | None = None
    transient_ratio: float = math.nan


class SequentialNoiseWatch:
    """Both CUSUMs per axis against ``v_ref`` (k,) [u²] within ``intervals``, at ``period`` [s] (as
    watch_noise_level)."""

    def __init__(self, v_ref: np.ndarray, intervals: list[tuple[float, float]], period: float, *, ratio: float,
                 false_alarms_per_hour: float, window_s: float = DEFAULT_WINDOW_S,
                 least_change: float | None = None, confirm_pairs: int = CONFIRM_MIN_PAIRS) -> None:
        self.v_ref = np.asarray(v_ref, dtype=float)
        k = self.v_ref.size
        self.reference_ci = [(math.sqrt(lo / v), math.sqrt(hi / v)) for (lo, hi), v in zip(intervals, self.v_ref,
                                                                                              strict=True)]
        self.least_change = math.sqrt(ratio) if least_change is None else least_change
        self.since_d2 = np.zeros(k)
        self.since_n = np.zeros(k, dtype=int)
        self.confirmed_s: list[float | None] = [None] * k
        self.confirm_pairs = confirm_pairs
        self.transients: list[tuple[LevelAlarm, float] | None] = [None] * k
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
        alarmed = np.array([a is not None for a in self.alarms])
        if alarmed.any():
            pending = alarmed & np.array([c is None for c in self.confirmed_s])
            self.since_d2[pending] += np.minimum(d2, self.cap[:, 0])[pending]  # a glitch counts as the CUSUM counts it
            self.since_n[pending] += 1
            for i in np.flatnonzero(pending & (self.since_n == self.confirm_pairs)):
                level = self._level(i)
                if level.sustained:
                    self.confirmed_s[i] = float(t)
                else:  # a transient: kept, and the axis watched afresh
                    self.transients[i] = (self.alarms[i], level.ratio)
                    self.alarms[i] = None
                    self.s[i] = 0.0
                    self.since_d2[i], self.since_n[i] = 0.0, 0
        weight = 1.0 - math.exp(-2.0 * max(t - t0, 0.0) / self.window_s) if self.pairs else 1.0
        current = d2 / self.v_ref
        self.mean_ratio2 = np.where(np.isnan(self.mean_ratio2), current,
                                    self.mean_ratio2 + weight * (current - self.mean_ratio2))
        self.pairs += 1

    def break_chain(self) -> None:
        """Motion or a gap: no pair across it."""
        self._pending = None

    def _level(self, i: int) -> NoiseLevel:
        ratio, ci = ratio_interval(self.since_d2[i] / self.since_n[i], int(self.since_n[i]), self.v_ref[i])
        return NoiseLevel(ratio, ci, self.alarms[i], self.h, int(self.since_n[i]), self.reference_ci[i],
                          self.least_change)

    def axis(self, i: int) -> AxisWatch:
        since = math.sqrt(self.since_d2[i] / self.since_n[i] / self.v_ref[i]) if self.since_n[i] else math.nan
        transient, transient_ratio = self.transients[i] or (None, math.nan)
        return AxisWatch(math.sqrt(self.mean_ratio2[i]) if self.pairs else math.nan, self.pairs, self.alarms[i],
                         self.confirmed_s[i], since, transient, transient_ratio)
