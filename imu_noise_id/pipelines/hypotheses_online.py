"""One IMU axis through the hypothesis bank: warm-up offset, then the bank — streaming or batch, same numbers.

The raw axis (a gyro reading including its turn-on bias and the Earth rate, or an accelerometer reading
including gravity) is not an error signal yet. The bank's constant-bias state absorbs any offset, but its
Gaussian prior (``bias_sigma``) must cover it; rather than a huge prior that also slows the bias estimate,
the mean of the first ``warmup`` seconds is subtracted from every sample (the warm-up samples are then fed
too), and ``bias_sigma`` only has to cover what is left. The node and ``imu-noise-id identify`` both use
:class:`AxisIdentifier`.
"""

from __future__ import annotations

import numpy as np

from ..core.errors import InputError
from ..core.hypotheses import BankResult, BankSnapshot, HypothesisBank, HypothesisSet
from ..core.hypotheses.kernel import check_samples


class AxisIdentifier:
    """Warm-up mean removal followed by a :class:`HypothesisBank`.

    Parameters
    ----------
    hypothesis_set : HypothesisSet
    warmup_s : float
        Duration [s] whose mean is removed (0: nothing removed; at least one sample is always used when > 0).
    """

    def __init__(self, hypothesis_set: HypothesisSet, warmup_s: float = 1.0) -> None:
        if not warmup_s >= 0:
            raise InputError(f"warm-up must be >= 0 s, got {warmup_s}")
        self.bank = HypothesisBank(hypothesis_set)
        self.n_warmup = max(1, round(warmup_s / hypothesis_set.dt)) if warmup_s > 0 else 0
        self.reset()

    def reset(self) -> None:
        """Forget everything, including the offset."""
        self.bank.reset()
        self._buffer: list[float] = []
        self.offset: float | None = None if self.n_warmup else 0.0

    def step(self, y: float) -> BankSnapshot | None:
        """One raw sample; None while the warm-up is collecting."""
        if self.offset is None:
            value = float(check_samples(y, "sample"))
            self._buffer.append(value)
            if len(self._buffer) < self.n_warmup:
                return None
            buf = np.array(self._buffer)
            self.offset = float(np.mean(buf))
            self._buffer = []
            self.bank.run(buf - self.offset)
            return self.bank.snapshot()
        return self.bank.step(float(y) - self.offset)

    def run(self, y: np.ndarray, record_every: int = 1) -> BankResult:
        """A whole raw series (the warm-up is its first ``n_warmup`` samples)."""
        arr = check_samples(y, "samples").ravel()
        if self.offset is not None:
            return self.bank.run(arr - self.offset, record_every)
        if arr.size < self.n_warmup:
            raise InputError(f"{arr.size} samples are fewer than the {self.n_warmup}-sample warm-up")
        self.offset = float(np.mean(arr[: self.n_warmup]))
        return self.bank.run(arr - self.offset, record_every)

    def gap(self, n_missing: int) -> None:
        """A pause of ``n_missing`` samples (see :meth:`HypothesisBank.gap`); during the warm-up it restarts it."""
        if self.offset is None:
            self._buffer = []
            return
        self.bank.gap(n_missing)
