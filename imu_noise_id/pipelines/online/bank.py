"""The online hypothesis bank (paper 002): an ``AxisIdentifier`` per axis fed batches of stationary stretches, pauses
as ``gap``; gyro axes keep the first warm-up offset, accelerometer stretches remove their own (docs/node.md)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...core.axes import AXES, sensor_of
from ...core.hypotheses.axis import AxisIdentifier
from ...core.hypotheses.config import hypothesis_set_factory
from .events import EventLog
from .results import HypothesesReport


@dataclass
class _Stretch:
    """Stationary samples of one uninterrupted stretch waiting for the hypothesis bank."""

    t: list[float] = field(default_factory=list)
    y: list[np.ndarray] = field(default_factory=list)
    closed: bool = False
    accel_offset: np.ndarray | None = None


#: A decision made at p ≥ γ is kept until p < γ − this (or another hypothesis reaches γ).
DECISION_HYSTERESIS = 0.1


def held_decision(previous: str | None, probabilities: Mapping[str, float], gamma: float,
                  hysteresis: float = DECISION_HYSTERESIS) -> str | None:
    """The decision with hysteresis: enter at p ≥ γ (paper 002's rule), leave below γ − ``hysteresis``."""
    best = max(probabilities, key=probabilities.__getitem__)
    if probabilities[best] >= gamma:
        return best
    if previous is not None and probabilities.get(previous, 0.0) >= gamma - hysteresis:
        return previous
    return None


class BankFeed:
    """The per-axis banks and the queue of stationary samples they have not seen; InputError on an invalid set.

    Parameters
    ----------
    data, source : the parsed hypothesis-set mapping and its origin (checked for both sensors now).
    bank_rate : rate of the bank's samples [Hz] (IMU samples block-averaged to it); events : decision changes go there.
    """

    def __init__(self, data: Mapping[str, Any], source: str, bank_rate: float, events: EventLog) -> None:
        for sensor in ("gyro", "accel"):
            hypothesis_set_factory(data, 0.01, sensor, source)
        self._data, self._source = data, source
        self._bank_rate = bank_rate
        self._events = events
        self._stretches: list[_Stretch] = []
        self._banks: list[AxisIdentifier] | None = None
        self._dt = math.nan
        self._warmup = 0
        self._last_t: float | None = None
        self._accel_first_offset: np.ndarray | None = None
        self._decisions: list[str | None] = [None] * 6
        # bank time [s] each held decision was made; the latest update's while it merges every hypothesis
        self._decided_at = [math.nan] * 6
        self.decision_changes: list[str] = []
        self.names: tuple[str, ...] = ()
        self.parameters: tuple[str, ...] = ()

    def add(self, t: float, sample: np.ndarray) -> None:
        """A stationary sample that passed the guard (queued until :meth:`feed`)."""
        if not self._stretches or self._stretches[-1].closed:
            self._stretches.append(_Stretch())
        stretch = self._stretches[-1]
        stretch.t.append(t)
        stretch.y.append(sample)

    def end_stretch(self) -> None:
        """Motion or a gap: the current stretch is complete."""
        if self._stretches:
            self._stretches[-1].closed = True

    def feed(self, rate: float) -> bool:
        """Feed the queue to the banks (created at the first call at IMU ``rate`` [Hz]); False when nothing to do."""
        if not self._stretches or not math.isfinite(rate):
            return False
        if self._banks is None:
            self._create(1.0 / rate)
        keep: list[_Stretch] = []
        for stretch in self._stretches:
            if not stretch.t:
                if not stretch.closed:
                    keep.append(stretch)
                continue
            if stretch.accel_offset is None:
                if len(stretch.t) < self._warmup and not stretch.closed:
                    keep.append(stretch)  # wait for its warm-up
                    continue
                n_warm = max(1, min(len(stretch.t), self._warmup))
                stretch.accel_offset = np.mean(np.array(stretch.y[:n_warm])[:, 3:], axis=0)
                if self._accel_first_offset is None:
                    self._accel_first_offset = stretch.accel_offset
            self._run(np.array(stretch.t), np.array(stretch.y), stretch)
            stretch.t, stretch.y = [], []
            if not stretch.closed:
                keep.append(stretch)
        self._stretches = keep
        return True

    def _create(self, dt: float) -> None:
        block = max(1, round(1.0 / (dt * self._bank_rate)))
        banks = []
        examples = []
        for axis in AXES:
            factory, warmup = hypothesis_set_factory(self._data, dt, sensor_of(axis), self._source)

            def make(wn_estimate: float | None, factory: Any = factory) -> Any:
                return dataclasses.replace(factory(wn_estimate), block=block)

            banks.append(AxisIdentifier(make, warmup, dt=dt))
            examples.append(make(1.0))  # for the names only (an ``auto`` range needs some estimate)
            self._warmup = banks[-1].n_warmup
        self._banks = banks
        self._dt = dt
        names: list[str] = []
        params: list[str] = []
        for hset in examples:
            for hyp in hset.hypotheses:
                if hyp.name not in names:
                    names.append(hyp.name)
                for p in hyp.parameter_names:
                    if p not in params:
                        params.append(p)
        self.names = tuple(names)
        self.parameters = tuple(params)

    def _run(self, t: np.ndarray, y: np.ndarray, stretch: _Stretch) -> None:
        dt = self._dt
        if self._last_t is not None:
            missing = round((t[0] - self._last_t) / dt) - 1
            if missing > 0:
                for bank in self._banks:
                    bank.gap(missing)
        self._last_t = float(t[-1])
        y = y.copy()
        y[:, 3:] += self._accel_first_offset - stretch.accel_offset
        for i, bank in enumerate(self._banks):
            column = y[:, i]
            if bank.bank is None and column.size < bank.n_warmup:
                column = np.concatenate([np.full(bank.n_warmup - column.size, column.mean()), column])
            bank.run(column)
            snap = bank.bank.snapshot()
            previous = self._decisions[i]
            decision = held_decision(previous, snap.decision_probabilities, bank.bank.hset.gamma)
            if decision != previous:
                if previous is None:
                    text = f"{AXES[i]}: decided {decision} (p = {snap.decision_probabilities[decision]:.3f})"
                else:
                    text = (f"{AXES[i]}: hypothesis decision changed from {previous} to {decision or 'undecided'} "
                            f"(p({previous}) = {snap.decision_probabilities.get(previous, 0.0):.3f})")
                text += "".join(f"; {g.text()}" for g in snap.long_memory)
                self.decision_changes.append(text)
                self._events.event(f"decision_{AXES[i]}", text)
                self._decisions[i] = decision
                self._decided_at[i] = math.nan if decision is None else float(snap.t)
            if snap.merges_every_hypothesis(decision):  # as of every sample so far, not of the first update
                self._decided_at[i] = float(snap.t)

    def report(self) -> HypothesesReport | None:
        """Posterior probabilities and decisions per axis, or None before the banks exist."""
        if self._banks is None:
            return None
        names = self.names
        probs = np.full((6, len(names)), math.nan)
        decision = np.full(6, -1.0)
        updates = np.zeros(6)
        notes = [""] * 6
        held, since, gamma = np.full(6, math.nan), np.full(6, math.nan), np.full(6, math.nan)
        for i, bank in enumerate(self._banks):
            if bank.bank is None:
                continue
            snap = bank.bank.snapshot()
            updates[i] = snap.n_updates
            if snap.n_updates == 0:
                continue
            notes[i] = "; ".join(g.text() for g in snap.long_memory)
            for name, p in snap.probabilities.items():
                probs[i, names.index(name)] = p
            gamma[i] = bank.bank.hset.gamma
            if self._decisions[i] is not None:
                decision[i] = names.index(self._decisions[i])
                held[i] = snap.decision_probabilities.get(self._decisions[i], 0.0)
                since[i] = self._decided_at[i]
        return HypothesesReport(names, probs, decision, updates, tuple(notes), held, since, gamma)

    def theta(self) -> dict[str, np.ndarray]:
        """Parameter → (6,) θ̂ of each axis's most probable hypothesis (long-memory GM merged into its RW twin); NaN
        where absent or unresolved."""
        if self._banks is None:
            return {}
        theta = {p: np.full(6, math.nan) for p in self.parameters}
        for i, bank in enumerate(self._banks):
            if bank.bank is None:
                continue
            snap = bank.bank.snapshot()
            if snap.n_updates == 0:
                continue
            best = max(snap.decision_probabilities, key=snap.decision_probabilities.get)
            for p, value in snap.hypotheses[best].theta.items():
                if p not in snap.hypotheses[best].not_identifiable:
                    theta[p][i] = value
        return theta
