"""Profile-likelihood intervals, for where the observed information cannot be trusted (beyond paper 000 §3.4).

Paper 000 §3.4 takes standard errors from the observed information: a Wald interval, right when the log-likelihood
is close to quadratic over the interval. An IMU fit often breaks that: a variance at its zero boundary (a random
walk the record cannot tell from 0, where the information has no inverse), a likelihood far from quadratic in
the log-parameters (a Gauss–Markov τ comparable with the record), parameters that trade against each other (a GM
of long τ against a random walk). Holding the other parameters at their estimates (a *conditional* interval)
ignores that trade and is too narrow. The profile likelihood

    ℓ_p(v) = max over ϑ_{−k} of ℓ(ϑ_k = v, ϑ_{−k})

gives the likelihood-ratio interval {v : 2(ℓ̂ − ℓ_p(v)) ≤ χ²₁(0.95)} (Cox & Hinkley 1974 §9.3; Venzon & Moolgavkar
1988), invariant to the parameterisation, with its lower end 0 where the data cannot exclude 0.

Each end is found on the signed root r(v) = √(2(ℓ̂ − ℓ_p(v))), nearly linear in |v − v̂| when ℓ is nearly
quadratic: first at the Wald end, outward by secant steps until r passes 1.96, then regula falsi (Illinois) until
|r − 1.96| < :data:`R_TOL`. Each ℓ_p(v) is an L-BFGS-B maximisation over the other parameters, warm-started on the
trace of the earlier points, in coordinates where it is well scaled:

* interior log-parameters whitened by their block of the observed information (Hessian ≈ identity);
* a parameter at its zero boundary *linearly*, as K/s (s its conditional upper 95 % end), with a floor at
  :data:`ZERO_FLOOR`·s, where it changes ℓ by a few hundredths at most (in its log it would sit on a flat
  plateau the search cannot leave);
* a parameter the information cannot see at all (not at 0: e.g. a GM τ with its σ at 0) in its log, one unit an
  e-fold, inside its physical range.

The ramp slope (a mean parameter, GLS-profiled inside ℓ) is profiled the same way, with its regressor fixed.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize

from .. import kalman
from ..kalman.statespace import StateSpace
from . import em, mle

#: Two-sided 95 % normal quantile: the signed root r at each end.
Z95 = 1.959963984540054
#: Each end is accepted when |r − Z95| is below this (an interval of 94.7–95.3 % nominal level).
R_TOL = 0.03
#: Zero-boundary parameters are searched in [ZERO_FLOOR·s, ZERO_CAP·s], s their conditional upper end.
ZERO_FLOOR, ZERO_CAP = 0.01, 1e4
#: An end further than this from the estimate (log units, i.e. a factor e^25 ≈ 7e10) is reported as unbounded.
MAX_LOG_DISTANCE = 25.0
#: Profile evaluations per end at most (outward steps and regula falsi together).
MAX_POINTS = 12
#: A profile point whose log-likelihood exceeds the fit's by more than this shows the fit missed the maximum.
BETTER_BY = 0.05
#: Drop of ℓ at which an inner maximisation counts as failed (an evaluation outside the filter's domain).
FAILED_DROP = 1e3


def whitening(info: np.ndarray) -> np.ndarray:
    """T with Tᵀ·info·T = I on the positive part of the spectrum (eigenvalues floored at 1e-8 of the largest)."""
    if info.size == 0:
        return np.zeros((0, 0))
    w, v = np.linalg.eigh(0.5 * (info + info.T))
    w = np.maximum(w, 1e-8 * max(float(np.max(w)), 1e-300))
    return v / np.sqrt(w)


@dataclass
class Profiler:
    """Profile likelihood of a fit's log-parameters (and ramp slope) on its record.

    Attributes
    ----------
    par, theta, model, y, z, ll_max
        The fit: parameterisation, log-parameters at the maximum, the state space there, the record, ℓ̂.
    info
        Observed information −∂²ℓ/∂ϑ² at the maximum (for whitening and the first steps).
    lo, hi
        Physical range of each log-parameter (GM τ, OSC/LPF frequencies; ±inf elsewhere).
    zero
        Parameters at the zero boundary → their scale s (conditional upper end).
    flat
        Parameters the information does not determine (searched in their log).
    """

    par: mle.Parameterisation
    theta: np.ndarray
    model: StateSpace
    y: np.ndarray
    z: np.ndarray
    ll_max: float
    info: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    zero: dict[int, float] = field(default_factory=dict)
    flat: set[int] = field(default_factory=set)
    n_eval: int = 0
    better: tuple[float, np.ndarray, StateSpace] | None = None

    def __post_init__(self) -> None:
        self.data = em.DataSums.of(self.y, self.z)

    # -- ℓ at one point ------------------------------------------------------------------------------------
    def loglik(self, theta: np.ndarray, base: StateSpace | None = None) -> float:
        """Exact profile log-likelihood (means by GLS) at ϑ; −inf outside the filter's domain."""
        self.n_eval += 1
        try:
            return float(kalman.loglik(self.par.to_model(theta, base or self.model), self.y, self.z).loglik)
        except (ValueError, np.linalg.LinAlgError):  # InputError is a ValueError
            return -math.inf

    def conditional_scale(self, k: int) -> float:
        """Where ℓ, the others held, first drops by the 95 % threshold going up from ϑ̂_k in e²-fold steps: the
        scale of a zero-boundary parameter (its conditional upper end, up to a factor e²)."""
        th = self.theta.copy()
        for step in range(1, int(MAX_LOG_DISTANCE / 2) + 1):
            th[k] = self.theta[k] + 2.0 * step
            if self.ll_max - self.loglik(th) > mle.LR_DROP_95:
                return float(np.exp(th[k]))
        return float(np.exp(th[k]))

    # -- the inner maximisation ----------------------------------------------------------------------------
    def maximise(self, starts: list[np.ndarray], skip: int | None, base: StateSpace) -> tuple[float, np.ndarray]:
        """max over the log-parameters but ``skip`` (held at its start value), from the best of ``starts``;
        (ℓ, argmax)."""
        start = starts[0] if len(starts) == 1 else max(starts, key=lambda t: self.loglik(t, base))
        free = [j for j in range(self.theta.size) if j != skip]
        zero = [j for j in free if j in self.zero]
        flat = [j for j in free if j in self.flat and j not in self.zero]
        inner = [j for j in free if j not in zero and j not in flat]
        T = whitening(self.info[np.ix_(inner, inner)])
        s = np.array([self.zero[j] for j in zero])
        ni, nz = len(inner), len(zero)
        start = np.where(np.isin(np.arange(start.size), zero), start, np.clip(start, self.lo, self.hi))

        def theta_of(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            th = start.copy()
            raw = start[inner] + T @ x[:ni]
            th[inner] = np.clip(raw, self.lo[inner], self.hi[inner])
            th[zero] = np.clip(np.log(s * x[ni:ni + nz]), self.lo[zero], self.hi[zero])
            th[flat] = np.clip(start[flat] + x[ni + nz:], self.lo[flat], self.hi[flat])
            return th, raw == th[inner]

        best: list = [-math.inf, start]

        def fun(x: np.ndarray) -> tuple[float, np.ndarray]:
            th, inside = theta_of(x)
            self.n_eval += 1
            try:
                ll, g, _ = mle.loglik_and_grad(self.par, th, base, self.y, self.z, data=self.data)
            except (ValueError, np.linalg.LinAlgError):  # InputError is a ValueError
                return FAILED_DROP, np.zeros_like(x)
            if not math.isfinite(ll):
                return FAILED_DROP, np.zeros_like(x)
            if ll > best[0]:
                best[:] = [ll, th]
            grad = np.concatenate([T.T @ (g[inner] * inside), g[zero] / x[ni:ni + nz], g[flat]])
            return self.ll_max - ll, -grad

        x0 = np.concatenate([np.zeros(ni),
                             np.clip(np.exp(start[zero]) / s, ZERO_FLOOR, ZERO_CAP) if nz else np.zeros(0),
                             np.zeros(len(flat))])
        bounds = ([(None, None)] * ni + [(ZERO_FLOOR, ZERO_CAP)] * nz
                  + [(self.lo[j] - start[j], self.hi[j] - start[j]) for j in flat])
        bounds = [(None if b is None or not math.isfinite(b) else b, None if c is None or not math.isfinite(c)
                   else c) for b, c in bounds]
        if free:
            minimize(fun, x0, jac=True, method="L-BFGS-B", bounds=bounds,
                     options={"maxiter": 25, "maxfun": 40, "ftol": 1e-9, "gtol": 1e-2, "maxcor": 10})
        else:
            fun(x0)
        ll, th = best
        if ll > self.ll_max + BETTER_BY and (self.better is None or ll > self.better[0]):
            self.better = (ll, th.copy(), base)
        return ll, th

    # -- one end --------------------------------------------------------------------------------------------
    def end(self, profile_at: Callable[[float, list[np.ndarray]], tuple[float, np.ndarray]], v_hat: float,
            direction: float, first: float, predict: Callable[[float], list[np.ndarray]], limit: float) -> float:
        """The end of the 95 % interval in ``direction`` (±1) of a profiled coordinate with estimate ``v_hat``.

        ``profile_at(v, starts)`` → (ℓ_p(v), argmax) from the best of ``starts``; ``first``: the first distance
        tried (e.g. the Wald half-width); ``predict(d)``: starts for the first point at distance d; ``limit``: the largest distance
        (±inf returned beyond it: the data do not bound the parameter that way).
        """
        pts: list[tuple[float, float, np.ndarray]] = [(0.0, 0.0, self.theta)]  # (distance, r, argmax)
        d = min(max(first, 1e-6), limit)
        inside: list[float] = [0.0, -Z95]  # Illinois regula falsi on f = r − Z95: [distance, f] with f < 0 …
        outside: list[float] | None = None  # … and with f > 0 once bracketed
        last_moved = 0  # which end the previous step replaced (−1 inside, +1 outside)
        for _ in range(MAX_POINTS):
            # The trace's guess, and the estimate itself (the profile can have a second, worse branch that
            # extrapolation walks into, e.g. a GM turning into a random walk at the largest τ).
            starts = predict(d) if len(pts) < 2 else [_extrapolate(pts, d), self.theta]
            ll, th = profile_at(v_hat + direction * d, starts)
            r = math.sqrt(2.0 * max(self.ll_max - ll, 0.0)) if math.isfinite(ll) else math.inf
            if abs(r - Z95) < R_TOL:
                return v_hat + direction * d
            if math.isfinite(r):
                pts.append((d, r, th))
            f = min(r - Z95, 10.0 * Z95)  # an evaluation outside the domain counts as far outside
            if f < 0 and d > inside[0]:
                inside = [d, f]
                if outside is not None and last_moved == -1:
                    outside[1] *= 0.5
                last_moved = -1
            elif f > 0 and (outside is None or d < outside[0]):
                outside = [d, f]
                if last_moved == 1:
                    inside[1] *= 0.5
                last_moved = 1
            if outside is None:  # still inside: step outward along the secant of r, 1.25–4× further
                if d >= limit:
                    return direction * math.inf
                near = sorted(pts, key=lambda p: p[0])[-2:]
                (d0, r0, _), (d1, r1, _) = near if len(near) == 2 else (pts[0], pts[0])
                grow = d0 + (Z95 - r0) * (d1 - d0) / (r1 - r0) if r1 > r0 else math.inf
                d = min(max(grow, 1.25 * d), 4.0 * d, limit)
                continue
            if outside[0] - inside[0] < 1e-3 * max(outside[0], 1e-3):
                break
            d = inside[0] - inside[1] * (outside[0] - inside[0]) / (outside[1] - inside[1])
        if outside is None:
            return direction * math.inf
        d = inside[0] - inside[1] * (outside[0] - inside[0]) / (outside[1] - inside[1])
        return v_hat + direction * d

    # -- a log-parameter ------------------------------------------------------------------------------------
    def interval(self, k: int, cov: np.ndarray, lower: bool = True) -> tuple[float, float]:
        """95 % profile interval (lo, hi) of log-parameter k (−inf: 0 cannot be excluded; +inf: unbounded).

        ``cov``: the Wald covariance (its column k predicts the trace's first point where finite);
        ``lower=False``: the lower end is −inf without searching (the caller knows the data cannot exclude 0).
        """
        theta_hat = self.theta
        col = cov[:, k] / cov[k, k] if math.isfinite(cov[k, k]) and cov[k, k] > 0 else np.zeros(theta_hat.size)
        col = np.where(np.isfinite(col), col, 0.0)
        col[list(self.zero) + list(self.flat)] = 0.0  # the trace's first guess moves the interior ones only
        se = math.sqrt(cov[k, k]) if math.isfinite(cov[k, k]) and cov[k, k] > 0 else math.inf

        def profile_at(v: float, starts: list[np.ndarray]) -> tuple[float, np.ndarray]:
            starts = [s.copy() for s in starts]
            for s in starts:
                s[k] = v
            return self.maximise(starts, k, self.model)

        out = []
        for direction in (-1.0, 1.0):
            if direction < 0 and not lower:
                out.append(-math.inf)
                continue
            v_hat = theta_hat[k]
            if k in self.zero and direction > 0:
                first = max(math.log(self.zero[k]) - 1.0 - v_hat, 0.5)  # inside [s/e², s], the conditional end
            else:
                first = Z95 * se if math.isfinite(se) and se < 5.0 else 1.0
            bound = self.hi[k] if direction > 0 else self.lo[k]
            limit = min(MAX_LOG_DISTANCE, abs(bound - v_hat)) if math.isfinite(bound) else MAX_LOG_DISTANCE

            def predict(d: float, direction: float = direction) -> list[np.ndarray]:
                return [np.clip(theta_hat + col * direction * d, self.lo, self.hi), theta_hat]

            end = self.end(profile_at, v_hat, direction, first, predict, limit)
            at_bound = math.isfinite(bound) and abs(end - bound) < 1e-9
            out.append(direction * math.inf if at_bound else end)
        return out[0], out[1]

    # -- the ramp slope -------------------------------------------------------------------------------------
    def slope_interval(self, regressor: int, value: float, se: float) -> tuple[float, float]:
        """95 % profile interval of the ramp slope (measurement regressor ``regressor``, GLS estimate ``value``,
        GLS standard error ``se`` given the noise parameters)."""
        fixed = self.model.copy()
        fixed.b_free[regressor] = False

        def profile_at(v: float, starts: list[np.ndarray]) -> tuple[float, np.ndarray]:
            base = fixed.copy()
            base.b[regressor] = v
            return self.maximise(starts, None, base)

        def predict(d: float) -> list[np.ndarray]:
            return [self.theta.copy()]

        scale = max(se, 1e-300)
        limit = 1e6 * scale
        lo = self.end(profile_at, value, -1.0, Z95 * scale, predict, limit)
        hi = self.end(profile_at, value, 1.0, Z95 * scale, predict, limit)
        return lo, hi


def _extrapolate(pts: list[tuple[float, float, np.ndarray]], d: float) -> np.ndarray:
    """Argmax at distance d by linear extrapolation (or interpolation) of the two nearest profile points."""
    near = sorted(pts, key=lambda p: abs(p[0] - d))[:2]
    (d0, _, t0), (d1, _, t1) = near
    if d1 == d0:
        return t0.copy()
    w = (d - d0) / (d1 - d0)
    w = min(max(w, -1.0), 2.0)
    return t0 + w * (t1 - t0)
