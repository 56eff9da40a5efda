"""Recursive Bayesian hypothesis bank (paper 002 section 2): streaming ``step`` and batch ``run`` (equal to ``step``
on every sample); ``gap`` declares missed samples (filters predict; an incomplete averaging block is dropped)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from .identifiable import LongMemory, long_memory, merged_probabilities
from .kernel import FilterBank, Posterior, check_samples
from .model import BankModel, HypothesisSet, build_bank_model


@dataclass(frozen=True)
class HypothesisEstimate:
    """Estimates under one hypothesis h_k (paper 002 eqs. 13–14): ``probability`` Pr(H = h_k | Y_i) (eq. 10);
    ``theta``, ``theta_std`` posterior mean θ̂^k and std by parameter name, continuous-time units; ``rsd`` theta_std /
    theta; ``not_identifiable`` parameter → lower bound, where the record cannot resolve it (:mod:`.identifiable`)."""

    probability: float
    theta: dict[str, float]
    theta_std: dict[str, float]
    rsd: dict[str, float]
    not_identifiable: dict[str, float] = field(default_factory=dict)


def probabilities_of(log_prob: np.ndarray) -> np.ndarray:
    """Normalised exponentials of log-probabilities along the last axis, clipped to [0, 1] (docs/hypotheses.md)."""
    lp = np.asarray(log_prob, dtype=float)
    p = np.exp(lp - np.max(lp, axis=-1, keepdims=True))
    return np.clip(p / np.sum(p, axis=-1, keepdims=True), 0.0, 1.0)


@dataclass(frozen=True)
class BankSnapshot:
    """The bank after its latest update: ``n_updates`` bank samples processed (block averages); ``t`` its time [s],
    gaps included; ``probabilities`` name → posterior probability; ``hypotheses`` name → :class:`HypothesisEstimate`;
    ``long_memory`` the GM hypotheses the data cannot tell from their RW twin; ``decision_probabilities`` those merged;
    ``decision`` the most probable hypothesis of ``decision_probabilities`` once it reaches γ, else None."""

    n_updates: int
    t: float
    probabilities: dict[str, float]
    decision: str | None
    hypotheses: dict[str, HypothesisEstimate]
    long_memory: tuple[LongMemory, ...] = ()
    decision_probabilities: dict[str, float] = field(default_factory=dict)

    def merged_into(self, decision: str) -> set[str]:
        """``decision`` and the long-memory GM hypotheses merged into it (those whose RW twin it is)."""
        return {decision} | {g.hypothesis for g in self.long_memory if g.twin == decision}

    def merges_every_hypothesis(self, decision: str | None) -> bool:
        """Whether ``decision`` takes in every hypothesis: its merged probability is then 1 at every update, and the
        decision rests on the merged GMs' τ bounds over the samples so far, not on a moment."""
        return decision is not None and self.merged_into(decision) >= set(self.probabilities)


@dataclass
class BankResult:
    """Time series of a batch run: ``t`` (N,) update times [s]; ``probabilities`` (N, K), columns in ``names`` order;
    ``theta``, ``theta_std`` name → (N, p_k) estimates and posterior stds; ``parameter_names`` name → its parameters'
    names; ``final`` the snapshot after the last update; ``gamma`` the decision threshold γ."""

    names: tuple[str, ...]
    t: np.ndarray
    probabilities: np.ndarray
    theta: dict[str, np.ndarray]
    theta_std: dict[str, np.ndarray]
    parameter_names: dict[str, tuple[str, ...]]
    final: BankSnapshot
    gamma: float

    @property
    def decision_time(self) -> float | None:
        """Time [s] from which ``final.decision`` (merged probability) stayed ≥ γ; ``final.t`` when only the last update
        reached it, or when the merge takes in every hypothesis (its probability is then 1 at every update, and the
        decision rests on the long-memory GMs' τ bounds over the whole record); None exactly when ``final.decision``
        is None."""
        decision = self.final.decision
        if decision is None:
            return None
        if self.final.merges_every_hypothesis(decision):
            return float(self.final.t)
        merged = self.final.merged_into(decision)
        p = np.minimum(1.0, self.probabilities[:, [k for k, n in enumerate(self.names) if n in merged]].sum(axis=1))
        below = np.flatnonzero(p < self.gamma)
        start = 0 if below.size == 0 else below[-1] + 1
        return float(self.t[start]) if start < self.t.size else float(self.final.t)


class HypothesisBank:
    """Bank of Kalman filters over the point-mass grids of the hypotheses of ``hypothesis_set`` (paper 002 eqs. 3–14);
    ``chunk``: bank samples per vectorised block in :meth:`run` (memory ∝ chunk × filters)."""

    def __init__(self, hypothesis_set: HypothesisSet, chunk: int = 64) -> None:
        self.hset = hypothesis_set
        self.model: BankModel = build_bank_model(hypothesis_set)
        self.chunk = int(chunk)
        self._filters = FilterBank(self.model, 1, hypothesis_set.gain_tolerance)
        self._parameter_names = [h.parameter_names for h in hypothesis_set.hypotheses]
        self.reset()

    @property
    def names(self) -> tuple[str, ...]:
        return self.hset.names

    @property
    def n_filters(self) -> int:
        return self.model.n_filters

    def reset(self) -> None:
        """Forget all data: prior probabilities, prior weights, prior states."""
        self._filters.reset()
        self._pending = np.zeros(0)
        self._ticks = 0  # bank sampling periods elapsed at the latest update, gaps included (t = ticks·bank_dt)
        self._n_updates = 0
        self._snapshot: BankSnapshot | None = None

    # -- feeding ---------------------------------------------------------------------------------------
    def _blocks(self, y: np.ndarray) -> np.ndarray:
        """Complete block averages of pending + y; keeps the remainder pending."""
        m = self.hset.block
        if m == 1:
            return y
        data = np.concatenate([self._pending, y])
        n_full = data.size // m
        self._pending = data[n_full * m:].copy()
        return data[: n_full * m].reshape(n_full, m).mean(axis=1)

    def _feed(self, y: np.ndarray, record_every: int) -> tuple[np.ndarray, np.ndarray]:
        """Advance the bank over y; cumulative log-likelihoods and times of the recorded updates."""
        ybar = self._blocks(y)
        if ybar.size == 0:
            return np.zeros((0, 1, self.n_filters)), np.zeros(0)
        self._snapshot = None
        lam, S = self._filters.advance(ybar[:, None])
        c = self._filters.accumulate(lam, S)
        index = self._n_updates + np.arange(1, ybar.size + 1)  # 1-based update numbers
        t = self.hset.bank_dt * (self._ticks + np.arange(1, ybar.size + 1))  # exact whatever the blocking
        self._ticks += ybar.size
        self._n_updates += ybar.size
        if record_every == 1:
            return c, t
        rows = np.flatnonzero(index % record_every == 0)
        return c[rows], t[rows]

    def step(self, y: float) -> BankSnapshot:
        """Feed one input sample and return the bank's state (the same object while an averaging block fills)."""
        value = float(y)
        if not math.isfinite(value):
            raise InputError(f"sample {y!r} is not finite: skip it (and call gap(1)) instead")
        self._feed(np.array([value]), 1)
        return self.snapshot()

    def run(self, y: np.ndarray, record_every: int = 1) -> BankResult:
        """Feed input samples; results after every ``record_every``-th bank update (counted from :meth:`reset`)."""
        arr = check_samples(y, "input samples").ravel()
        if arr.size == 0:
            raise InputError("no input samples given to the hypothesis bank")
        if int(record_every) != record_every or record_every < 1:
            raise InputError(f"record_every must be an integer >= 1, got {record_every!r}")
        K = len(self.names)
        logp, ts = [], []
        means: list[list[np.ndarray]] = [[] for _ in range(K)]
        variances: list[list[np.ndarray]] = [[] for _ in range(K)]
        step = self.chunk * self.hset.block
        for start in range(0, arr.size, step):
            c, t = self._feed(arr[start:start + step], int(record_every))
            post = self._filters.evaluate(c)
            logp.append(post.log_prob[:, 0])
            ts.append(t)
            for k in range(K):
                means[k].append(post.theta_mean[k][:, 0])
                variances[k].append(post.theta_var[k][:, 0])
        if t.size and self._n_updates % record_every == 0:
            # The last row recorded is the latest update: the snapshot reads it rather than evaluating it again
            # (evaluate treats every row on its own, so the numbers are the same).
            self._snapshot = self._snapshot_of(Posterior(
                post.log_prob[-1:], [m[-1:] for m in post.theta_mean], [v[-1:] for v in post.theta_var]))
        return BankResult(
            names=self.names,
            t=np.concatenate(ts),
            probabilities=probabilities_of(np.concatenate(logp)),
            theta={n: np.concatenate(means[k]) for k, n in enumerate(self.names)},
            theta_std={n: np.sqrt(np.concatenate(variances[k])) for k, n in enumerate(self.names)},
            parameter_names={h.name: h.parameter_names for h in self.hset.hypotheses},
            final=self.snapshot(),
            gamma=self.hset.gamma,
        )

    def gap(self, n_missing: int) -> None:
        """Declare ``n_missing`` input samples that were not fed (a pause); see the module docstring."""
        if int(n_missing) != n_missing or n_missing < 0:
            raise InputError(f"gap must be a whole number of samples >= 0, got {n_missing!r}")
        m = self.hset.block
        missed = int(n_missing) + self._pending.size  # the incomplete block is dropped
        self._pending = np.zeros(0)
        blocks = missed // m
        self._filters.gap(blocks)
        self._ticks += blocks
        self._snapshot = None

    # -- reading ---------------------------------------------------------------------------------------
    def snapshot(self) -> BankSnapshot:
        """Probabilities, decision, θ̂ and RSD per hypothesis after the latest update (cached until the next)."""
        if self._snapshot is None:
            self._snapshot = self._snapshot_of(self._filters.evaluate(self._filters.c[None]))
        return self._snapshot

    def _snapshot_of(self, post: Posterior) -> BankSnapshot:
        """The snapshot of the latest update from its posterior (one row)."""
        probs = probabilities_of(post.log_prob[0, 0]).tolist()
        t = self.hset.bank_dt * self._ticks
        lj = self._filters.c[0] + self.model.log_mu0
        longs = long_memory(self.hset, [lj[sl] for sl in self.model.slices], t) if self._n_updates else []
        bounds = {g.hypothesis: {"GM.tau": g.tau_lower_bound} for g in longs}
        hyps = {}
        for k, name in enumerate(self.names):
            mean = post.theta_mean[k][0, 0].tolist()
            std = np.sqrt(np.maximum(post.theta_var[k][0, 0], 0.0)).tolist()
            names = self._parameter_names[k]
            hyps[name] = HypothesisEstimate(
                probability=probs[k],
                theta=dict(zip(names, mean, strict=True)),
                theta_std=dict(zip(names, std, strict=True)),
                rsd={p: (s / v if v > 0 else math.inf) for p, s, v in zip(names, std, mean, strict=True)},
                not_identifiable=bounds.get(name, {}),
            )
        probabilities = dict(zip(self.names, probs, strict=True))
        merged = merged_probabilities(probabilities, longs)
        best = max(merged, key=merged.__getitem__)
        return BankSnapshot(
            n_updates=self._n_updates, t=t, probabilities=probabilities,
            decision=best if merged[best] >= self.hset.gamma else None, hypotheses=hyps,
            long_memory=tuple(longs), decision_probabilities=merged,
        )

    def state_estimates(self) -> dict[str, dict[str, tuple[float, float]]]:
        """Per hypothesis, mixture state estimates and stds (eqs. 13–14) [u] by state name (``bias``, ``RW``, …)."""
        out = {}
        for k, (mean, cov) in enumerate(self._filters.state_mixture(0)):
            std = np.sqrt(np.maximum(np.diag(cov), 0.0))
            out[self.names[k]] = {n: (float(m), float(s)) for n, m, s in
                                  zip(self.model.state_names[k], mean, std, strict=True)}
        return out
