"""One IMU axis through the hypothesis bank after removing the mean of the first ``warmup`` seconds (which also gives
the white-noise estimate for ``auto`` ranges); used by the node and ``imu-noise-id identify``."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import InputError
from .bank import BankResult, BankSnapshot, HypothesisBank
from .config import white_noise_estimate
from .kernel import check_samples
from .model import HypothesisSet


class AxisIdentifier:
    """Warm-up mean removal followed by a :class:`HypothesisBank`: ``hypotheses`` a HypothesisSet, or white-noise
    estimate [u/√Hz] → HypothesisSet (:func:`.config.hypothesis_set_factory`); ``warmup_s`` [s] whose mean is removed
    (0: none; at least 3 samples when > 0); ``dt`` input sampling period [s] (required with a function). InputError
    on invalid arguments."""

    def __init__(self, hypotheses: HypothesisSet | Callable[[float | None], HypothesisSet], warmup_s: float = 1.0,
                 dt: float | None = None) -> None:
        if not warmup_s >= 0:
            raise InputError(f"warm-up must be >= 0 s, got {warmup_s}")
        if isinstance(hypotheses, HypothesisSet):
            self._make: Callable[[float | None], HypothesisSet] = lambda _est: hypotheses
            dt = hypotheses.dt
        else:
            self._make = hypotheses
            if dt is None or not dt > 0:
                raise InputError("AxisIdentifier needs the sampling period dt with a hypothesis-set function")
        self.dt = float(dt)
        self.n_warmup = max(3, round(warmup_s / self.dt)) if warmup_s > 0 else 0
        self.bank: HypothesisBank | None = None
        self.reset()

    def reset(self) -> None:
        """Forget everything, including the offset and the white-noise estimate."""
        self._buffer: list[float] = []
        self.offset: float | None = None
        self.wn_estimate: float | None = None
        self.bank = None
        if self.n_warmup == 0:
            self._start(np.zeros(0))

    def _start(self, warm: np.ndarray) -> None:
        """Offset, white-noise estimate and the bank from the warm-up samples."""
        self.offset = float(np.mean(warm)) if warm.size else 0.0
        self.wn_estimate = white_noise_estimate(warm, self.dt) if warm.size else None
        self.bank = HypothesisBank(self._make(self.wn_estimate))

    def step(self, y: float) -> BankSnapshot | None:
        """One raw sample; None while the warm-up is collecting."""
        if self.bank is None:
            self._buffer.append(float(check_samples(y, "sample")))
            if len(self._buffer) < self.n_warmup:
                return None
            buf = np.array(self._buffer)
            self._buffer = []
            self._start(buf)
            self.bank.run(buf - self.offset)
            return self.bank.snapshot()
        return self.bank.step(float(y) - self.offset)

    def run(self, y: np.ndarray, record_every: int = 1) -> BankResult:
        """A whole raw series (the warm-up is its first ``n_warmup`` samples)."""
        arr = check_samples(y, "samples").ravel()
        if self.bank is None:
            if arr.size < self.n_warmup:
                raise InputError(f"{arr.size} samples are fewer than the {self.n_warmup}-sample warm-up")
            self._start(arr[: self.n_warmup])
        return self.bank.run(arr - self.offset, record_every)

    def gap(self, n_missing: int) -> None:
        """A pause of ``n_missing`` samples (see :meth:`HypothesisBank.gap`); during the warm-up it restarts it."""
        if self.bank is None:
            self._buffer = []
            return
        self.bank.gap(n_missing)


def identify_offline(y: np.ndarray, hypotheses: HypothesisSet | Callable[[float | None], HypothesisSet],
                     warmup_s: float, dt: float, *, refine: int = 0,
                     record_every: int = 1) -> tuple[BankResult, AxisIdentifier, int]:
    """Batch identification of one raw axis with up to ``refine`` passes of :func:`.model.refine_hypothesis_set` (stops
    when no range moves by > 1 %); returns the last result, its identifier and the passes run."""
    from .model import refine_hypothesis_set

    ident = AxisIdentifier(hypotheses, warmup_s, dt)
    result = ident.run(y, record_every)
    passes = 1
    for _ in range(int(refine)):
        final = result.final
        old = ident.bank.hset
        new = refine_hypothesis_set(old, {h: e.theta for h, e in final.hypotheses.items()},
                                    {h: e.theta_std for h, e in final.hypotheses.items()})
        changed = any(
            not np.allclose(p_new.edges()[[0, -1]], p_old.edges()[[0, -1]], rtol=0.01)
            for h_new, h_old in zip(new.hypotheses, old.hypotheses, strict=True)
            for p_new, p_old in zip(h_new.priors, h_old.priors, strict=True) if not p_new.known
        )
        if not changed:
            break
        wn = ident.wn_estimate
        ident = AxisIdentifier(new, warmup_s, dt)  # same warm-up, so the same offset
        result = ident.run(y, record_every)
        ident.wn_estimate = wn  # the estimate that centred the first pass' auto range
        passes += 1
    return result, ident, passes
