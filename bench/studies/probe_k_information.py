"""How well *any* estimator could know K in bench_loop_effects' GM cases: the Cramér–Rao bound of K and the
random walk a model without the GM converges to (docs/loop.md, "Limitations"; issue 11's "K within 35 %").

Run:  PYTHONPATH=$PWD nice -n 10 python bench/studies/probe_k_information.py [--seeds 10] [--minutes 20 120]
(output: docs/results/studies/probe_k_information.txt; a few seconds per case; no simulation, no fit)

For a Gaussian process whose first difference is stationary, the Fisher information of n samples is, to leading
order in n, Whittle's (Whittle 1953; Brockwell & Davis 1991, §10.8):

    I_ij = Σ_k ∂ln S(ω_k)/∂θ_i · ∂ln S(ω_k)/∂θ_j,   ω_k = 2πk/(n − 1), k = 1 … ⌊(n − 2)/2⌋,

with S the spectral density of Δy (``core.estimation.whittle.difference_spectrum``) and θ the log-parameters of
every component (WN, RW, GM, and the OSC of the case at its seed). ``sd(ln K)`` = √(I⁻¹)_KK is then the smallest
standard deviation of ln K̂ an unbiased estimator *that knows the structure* can have; an efficient one is within
35 % of K (ln 0.65 ≤ ln K̂/K ≤ ln 1.35) with probability ``P35`` under the normal approximation, and ``miss/10``
is how many of ten seeds it is expected to miss by more.

For a model *without* the GM (WN + RW (+ OSC), what the loop keeps when it does not find the GM), the pseudo-true
parameters minimise the expected Whittle divergence Σ_k [ln S_m(ω_k) + S(ω_k)/S_m(ω_k)]: ``K without GM`` is the
random walk that model converges to as the record grows (its bias), and ``E gain`` = Σ_k [ln(S_m/S) + S/S_m − 1]
at that optimum is the expected log-likelihood the GM buys over it (the same sum at any n: it grows ∝ n), against
``BIC asks`` = ½·2·ln n for the GM's two parameters. ``T for BIC`` is the record length at which the expected gain
reaches what the BIC asks; ``P add`` = P(χ'²₂(2·E gain) > 2·BIC asks), the chance that the likelihood-ratio
statistic of the true structure clears the BIC in one record (a noncentral χ² with the GM's two degrees of freedom:
an approximation, as τ is not identified when σ = 0).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # bench/, for its shared helpers

import numpy as np
from bench_loop_effects import DT, GMS, K_TRUE, N_TRUE, simulate
from scipy.optimize import minimize
from scipy.stats import ncx2, norm

from imu_noise_id.core.estimation.em.mle import Parameterisation
from imu_noise_id.core.estimation.em.whittle import difference_spectrum
from imu_noise_id.core.noise.components import GM, RW, WN, Component

#: |K̂/K − 1| ≤ this is issue 11's target.
K_TOLERANCE = 0.35


def fourier_omega(n: int) -> np.ndarray:
    """Angular Fourier frequencies [rad/sample] of the n − 1 differences, excluding 0 and π."""
    m = n - 1
    return 2.0 * math.pi * np.arange(1, (m - 1) // 2 + 1) / m


def fisher_information(components: list[Component], omega: np.ndarray, step: float = 1e-5,
                       dt: float = DT) -> np.ndarray:
    """Σ_k g_k g_kᵀ with g_k = ∂ln S(ω_k)/∂θ in the log-parameters (central differences of ln S) at period ``dt``
    [s]."""
    par = Parameterisation.of(components)
    x0 = par.to_theta(components)
    grads = []
    for j in range(x0.size):
        e = np.zeros_like(x0)
        e[j] = step
        up = np.log(difference_spectrum(par.to_components(x0 + e), omega, dt))
        down = np.log(difference_spectrum(par.to_components(x0 - e), omega, dt))
        grads.append((up - down) / (2.0 * step))
    g = np.array(grads)
    return g @ g.T


def pseudo_true(truth: list[Component], model: list[Component], omega: np.ndarray) -> tuple[list[Component], float]:
    """(model minimising the expected Whittle divergence from ``truth``, that divergence Σ[ln(S_m/S) + S/S_m − 1])."""
    s_true = difference_spectrum(truth, omega, DT)
    par = Parameterisation.of(model)

    def divergence(x: np.ndarray) -> float:
        s = difference_spectrum(par.to_components(x), omega, DT)
        r = s_true / s
        return float(np.sum(r - np.log(r) - 1.0))

    res = minimize(divergence, par.to_theta(model), method="Nelder-Mead",
                   options={"xatol": 1e-6, "fatol": 1e-6, "maxiter": 4000, "maxfev": 8000})
    res = minimize(divergence, res.x, method="L-BFGS-B")
    return par.to_components(res.x), float(res.fun)


def case_components(case: str, seed: int) -> list[Component]:
    """The true components of a bench_loop_effects record (WN first, RW second)."""
    _, truth = simulate(case, seed, 16)  # the draws that set the line come before the samples
    comps: list[Component] = [WN(N_TRUE), RW(K_TRUE)]
    if "osc" in truth:
        comps.append(truth["osc"])
    if case in GMS:
        comps.append(GMS[case])
    return comps


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3, help="OSC draws per line case (K's bound barely depends on them)")
    ap.add_argument("--minutes", type=float, nargs="+", default=[20.0, 120.0])
    ap.add_argument("--cases", nargs="+", default=["clean", "gm", "osc+gm", "osc+fast_gm", "osc+clear_gm"])
    args = ap.parse_args()
    print(f"# bench/studies/probe_k_information.py --seeds {args.seeds} "
          f"--minutes {' '.join(f'{m:g}' for m in args.minutes)} (100 Hz; N = {N_TRUE}, K = {K_TRUE}; "
          f"seeds 1000 … as bench_loop_effects)")
    for minutes in args.minutes:
        n = int(minutes * 60 / DT)
        omega = fourier_omega(n)
        for case in args.cases:
            sds, biases, gains = [], [], []
            for seed in range(1000, 1000 + (args.seeds if "osc" in case else 1)):
                comps = case_components(case, seed)
                info = fisher_information(comps, omega)
                sds.append(math.sqrt(np.linalg.inv(info)[1, 1]))  # RW's only parameter is the second
                if case in GMS:
                    without, divergence = pseudo_true(comps, [c for c in comps if not isinstance(c, GM)], omega)
                    biases.append(next(c for c in without if isinstance(c, RW)).random_walk / K_TRUE - 1.0)
                    gains.append(divergence)
            sd = float(np.median(sds))
            p35 = float(norm.cdf(math.log(1 + K_TOLERANCE) / sd) - norm.cdf(math.log(1 - K_TOLERANCE) / sd))
            line = (f"{minutes:5g} min {case:13s} CRB sd(ln K) {sd:5.3f} (seeds {min(sds):.3f}-{max(sds):.3f})"
                    f"  P35 {p35:5.3f}  miss/10 {10 * (1 - p35):4.2f}")
            if gains:
                gain = float(np.median(gains))
                asks = math.log(n)
                t_bic = minutes * asks / gain  # gain ∝ n; ln n grows slowly: one fixed-point step is enough
                t_bic = minutes * math.log(n * t_bic / minutes) / gain
                p_add = float(ncx2.sf(2.0 * asks, 2, 2.0 * gain))
                line += (f"  K without GM {100 * float(np.median(biases)):+5.1f} %  E gain {gain:6.2f}"
                         f"  BIC asks {asks:5.2f}  P add {p_add:5.3f}  T for BIC {t_bic:6.0f} min")
            print(line, flush=True)


if __name__ == "__main__":
    main()
