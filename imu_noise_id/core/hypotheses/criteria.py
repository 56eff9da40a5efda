"""Performance criteria of the identification (paper 002 section 3) by Monte Carlo, and the section 4 cases: per
trial the true hypothesis from the prior, θ uniform over the ranges; real (eq. 15) and calculated (eq. 18, 1 − Pr of
the most probable; ``_true``: 1 − Pr(true)) error probabilities, parameter error variances (17, 19), RSDs (20)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..noise.components import GM, RW, WN, Component
from .kernel import FilterBank
from .model import Hypothesis, HypothesisSet, ParameterPrior, build_bank_model

#: Longest block of samples processed in one vectorised step (memory ∝ block × trials × filters).
_MAX_BLOCK = 16


@dataclass
class CriteriaResult:
    """Performance criteria over time (paper 002 eqs. 15, 17–20): ``t`` (R,) times [s]; ``error_probability_real``,
    ``error_probability_calculated`` (R,) eqs. (15), (18); ``error_probability_calculated_true`` (R,) mean of
    1 − Pr(true hypothesis); ``rsd_real``, ``rsd_calculated`` ``"<hypothesis>:<parameter>"`` → (R,) eq. (20) from eqs.
    (17) / (19); ``decided``, ``decided_wrong`` (R,) fraction of trials with a decision (max Pr ≥ γ), and with a wrong
    one; ``true_counts`` hypothesis → trials it was true in."""

    case: str
    trials: int
    dt: float
    t: np.ndarray
    error_probability_real: np.ndarray
    error_probability_calculated: np.ndarray
    rsd_real: dict[str, np.ndarray]
    rsd_calculated: dict[str, np.ndarray]
    decided: np.ndarray
    decided_wrong: np.ndarray
    true_counts: dict[str, int]
    error_probability_calculated_true: np.ndarray
    settings: dict = field(default_factory=dict)


def paper_case(case: int, dt: float = 1.0, grid: dict[str, int] | None = None, bias_sigma: float = 1.0,
               gamma: float = 0.8) -> HypothesisSet:
    """Paper 002 section 4, case 1, 2 or 3: RW (eq. 21) vs GM (eq. 22) with a bias, eq. (23); InputError otherwise.

    Per sample σ_w ∈ [0.04, 0.15] u, τ_m ∈ [1, 25] min, σ_m ∈ [0.5, 1.5] u, σ_v = 0 / 0.5 u / ∈ [0.25, 1] u
    (random_walk = σ_w/√Δt, noise_density = σ_v·√Δt); ``grid``: log-grid sizes; bias ~ N(0, bias_sigma²)."""
    if case not in (1, 2, 3):
        raise InputError(f"paper 002 has cases 1, 2 and 3, got {case!r}")
    sizes = {"random_walk": 256, "tau": 32, "sigma": 32, "noise_density": 8}
    if case == 3:
        sizes.update({"random_walk": 64, "tau": 12, "sigma": 12, "noise_density": 12})
    sizes.update(grid or {})
    rt = math.sqrt(dt)
    rw = ParameterPrior("RW.random_walk", 0.04 / rt, 0.15 / rt, sizes["random_walk"], "log")
    tau = ParameterPrior("GM.tau", 60.0, 1500.0, sizes["tau"], "log")
    sig = ParameterPrior("GM.sigma", 0.5, 1.5, sizes["sigma"], "log")
    if case == 1:
        h1 = Hypothesis(("RW",), (rw,))
        h2 = Hypothesis(("GM",), (tau, sig))
    else:
        wn = (ParameterPrior("WN.noise_density", 0.5 * rt, 0.5 * rt, 1) if case == 2
              else ParameterPrior("WN.noise_density", 0.25 * rt, 1.0 * rt, sizes["noise_density"], "log"))
        h1 = Hypothesis(("RW", "WN"), (rw, wn))
        h2 = Hypothesis(("GM", "WN"), (tau, sig, wn))
    return HypothesisSet((h1, h2), dt=dt, gamma=gamma, bias_sigma=bias_sigma)


def true_components(hyp: Hypothesis, theta: np.ndarray) -> list[Component]:
    """The components of hypothesis ``hyp`` with parameter vector ``theta`` (in ``hyp.parameter_names`` order)."""
    v = dict(zip(hyp.parameter_names, theta, strict=True))
    comps: list[Component] = []
    for c in hyp.components:
        if c == "RW":
            comps.append(RW(v["RW.random_walk"]))
        elif c == "GM":
            comps.append(GM(v["GM.tau"], v["GM.sigma"]))
        elif v["WN.noise_density"] > 0:
            comps.append(WN(v["WN.noise_density"]))
    return comps


def simulate_trial(hset: HypothesisSet, k: int, theta: np.ndarray, n_samples: int,
                   rng: np.random.Generator) -> np.ndarray:
    """``n_samples`` inputs of hypothesis k with θ and a N(0, bias_sigma²) bias; RW from 0, GM stationary."""
    y = np.full(n_samples, rng.standard_normal() * hset.bias_sigma)
    for comp in true_components(hset.hypotheses[k], theta):
        y += comp.simulate(n_samples, hset.dt, rng)
    return y


def draw_truths(hset: HypothesisSet, trials: int, rng: np.random.Generator) -> tuple[np.ndarray, list[np.ndarray]]:
    """True hypothesis per trial (from the prior probabilities) and θ uniform over the prior ranges."""
    prior = np.array([h.probability for h in hset.hypotheses], dtype=float)
    ks = rng.choice(len(prior), size=trials, p=prior / prior.sum())
    thetas = [np.array([rng.uniform(p.low, p.high) for p in hset.hypotheses[k].priors]) for k in ks]
    return ks, thetas


def record_indices(n_updates: int, n_points: int = 200) -> np.ndarray:
    """Update numbers (1-based) at which to record: the first 10 and then about ``n_points`` log/linear spaced."""
    early = np.arange(1, min(10, n_updates) + 1)
    logs = np.geomspace(1, n_updates, n_points // 2).round()
    lins = np.linspace(1, n_updates, n_points // 2).round()
    return np.unique(np.concatenate([early, logs, lins]).astype(int))


def run_criteria(hset: HypothesisSet, duration_s: float, trials: int, *, seed: int | None = 0,
                 record: np.ndarray | None = None, trial_batch: int = 50, case: str = "",
                 progress: Callable[[int, int], None] | None = None) -> CriteriaResult:
    """Monte-Carlo criteria of the bank on ``hset`` over ``duration_s`` [s] at ``record`` update numbers,
    ``trial_batch`` trials per bank, ``progress(done, total)``; InputError on too few trials or bad records."""
    if trials < 2:
        raise InputError(f"the Monte Carlo needs at least 2 trials, got {trials}")
    n_updates = round(duration_s / hset.bank_dt)
    if n_updates < 1:
        raise InputError(f"duration {duration_s} s is shorter than one bank sample ({hset.bank_dt} s)")
    rec = record_indices(n_updates) if record is None else np.unique(np.asarray(record, dtype=int))
    if rec.size == 0 or rec[0] < 1 or rec[-1] > n_updates:
        raise InputError(f"record indices must lie in [1, {n_updates}]")
    rng = np.random.default_rng(seed)
    model = build_bank_model(hset)
    K = len(hset.hypotheses)
    R = rec.size
    ks, thetas = draw_truths(hset, trials, rng)
    err_real, err_calc, err_calc_true, decided, wrong = (np.zeros(R) for _ in range(5))
    keys = [(k, q) for k, h in enumerate(hset.hypotheses) for q in range(len(h.priors)) if not h.priors[q].known]
    sq = {kq: np.zeros(R) for kq in keys}
    var = {kq: np.zeros(R) for kq in keys}
    m = hset.block
    for b0 in range(0, trials, trial_batch):
        idx = np.arange(b0, min(trials, b0 + trial_batch))
        y = np.stack([simulate_trial(hset, ks[i], thetas[i], n_updates * m, rng) for i in idx])
        ybar = y.reshape(idx.size, n_updates, m).mean(axis=2).T.copy() if m > 1 else y.T.copy()
        bank = FilterBank(model, idx.size, hset.gain_tolerance)
        true_k = ks[idx]
        done = 0
        for r, upto in enumerate(rec):
            while done < upto:
                stop = min(upto, done + _MAX_BLOCK)
                lam, S = bank.advance(ybar[done:stop])
                bank.accumulate(lam, S)
                done = stop
            post = bank.evaluate(bank.c[None])
            prob = np.exp(post.log_prob[0])  # (L, K)
            best = prob.argmax(axis=1)
            err_real[r] += np.sum(best != true_k)
            err_calc[r] += np.sum(1.0 - prob.max(axis=1))
            err_calc_true[r] += np.sum(1.0 - prob[np.arange(idx.size), true_k])
            dec = prob.max(axis=1) >= hset.gamma
            decided[r] += dec.sum()
            wrong[r] += np.sum(dec & (best != true_k))
            for k, q in keys:
                sel = np.flatnonzero(true_k == k)
                if sel.size:
                    truth = np.array([thetas[i][q] for i in idx[sel]])
                    sq[(k, q)][r] += np.sum((truth - post.theta_mean[k][0, sel, q]) ** 2)
                    var[(k, q)][r] += np.sum(post.theta_var[k][0, sel, q])
            if progress is not None:
                progress(b0 * R + idx.size * (r + 1), trials * R)
    counts = {h.name: int(np.sum(ks == k)) for k, h in enumerate(hset.hypotheses)}
    rsd_real, rsd_calc = {}, {}
    for k, q in keys:
        h = hset.hypotheses[k]
        n_k = counts[h.name]
        name = f"{h.name}:{h.priors[q].name}"
        mean = h.priors[q].mean
        rsd_real[name] = np.sqrt(sq[(k, q)] / max(n_k - 1, 1)) / mean
        rsd_calc[name] = np.sqrt(var[(k, q)] / max(n_k, 1)) / mean
    return CriteriaResult(
        case=str(case), trials=trials, dt=hset.dt, t=rec * hset.bank_dt,
        error_probability_real=err_real / trials, error_probability_calculated=err_calc / trials,
        rsd_real=rsd_real, rsd_calculated=rsd_calc, decided=decided / trials, decided_wrong=wrong / trials,
        true_counts=counts, error_probability_calculated_true=err_calc_true / trials,
        settings={"duration_s": duration_s, "seed": seed, "n_filters": model.n_filters, "block": m,
                  "bias_sigma": hset.bias_sigma, "gamma": hset.gamma, "K": K,
                  "grids": {h.name: {p.name: [p.low, p.high, p.n, p.spacing] for p in h.priors}
                            for h in hset.hypotheses}},
    )
