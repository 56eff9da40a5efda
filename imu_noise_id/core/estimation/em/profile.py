"""Adjusted profile-likelihood intervals where the observed information cannot be trusted (beyond paper 000 §3.4).

Profile likelihood (Cox & Hinkley 1974 §9.3; Venzon & Moolgavkar 1988) ℓ_p(v) = max over ϑ_{−k} of ℓ(ϑ_k = v, ϑ_{−k}),
adjusted for the GLS-estimated bias and ramp (Cox & Reid 1987, eq. 4; restricted likelihood of Patterson & Thompson
1971, cf. Tunnicliffe Wilson 1989):

    ℓ_A(v) = ℓ_p(v) − ½ log det(Zᵀ V⁻¹ Z)(v) = ℓ_p(v) + ½ log det cov(b̂)(v);

the adjustment at ℓ_p's argmax; interval {v : ℓ_A(v) ≥ max ℓ_A − 1.92}, lower end 0 where 0 cannot be excluded; point
estimates stay the ML ones. Searched by :mod:`.profile_search`: interior log-parameters whitened by their
information, zero-boundary ones linearly as K/s (scaled by ℓ_A's curvature along the ladder of starts), undetermined
ones in their log within their physical range."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize

from ... import kalman
from ...kalman.common import ProfileResult
from ...kalman.statespace import StateSpace
from . import em, mle
from .profile_search import Z95, centre, end

#: Zero-boundary parameters are searched in [ZERO_FLOOR·s, ZERO_CAP·s], s their conditional upper end.
ZERO_FLOOR, ZERO_CAP = 0.01, 1e4
#: Log offsets from s at which a zero-boundary parameter also starts inner maximisations (see Profiler.with_ladder).
ZERO_LADDER = (1.0, 0.0, -1.0, -2.0, -3.0)
#: An end further than this from the estimate (log units, i.e. a factor e^25 ≈ 7e10) is reported as unbounded.
MAX_LOG_DISTANCE = 25.0
#: A profile point whose log-likelihood exceeds the fit's by more than this shows the fit missed the maximum.
BETTER_BY = 0.05
#: The inner maximisation moves the interior parameters at most this many standard errors from its start.
MAX_WHITENED = 20.0
#: Drop of ℓ at which an inner maximisation counts as failed (an evaluation outside the filter's domain).
FAILED_DROP = 1e3
#: Likelihood evaluations one inner maximisation's L-BFGS-B may spend (its ``maxfun``).
MAX_FUN = 12



def whitening(info: np.ndarray) -> np.ndarray:
    """T with Tᵀ·info·T = I on the positive part of the spectrum (eigenvalues floored at 1e-8 of the largest)."""
    if info.size == 0:
        return np.zeros((0, 0))
    w, v = np.linalg.eigh(0.5 * (info + info.T))
    w = np.maximum(w, 1e-8 * max(float(np.max(w)), 1e-300))
    return v / np.sqrt(w)


def rung_curvature(points: list[tuple[float, float]]) -> float:
    """−d²ℓ_A/dx² at the best of ``points`` (x, ℓ_A): the second divided difference through it and its neighbours in
    x; NaN where it has no neighbour on one side or ℓ_A does not bend there."""
    pts = sorted(p for p in points if math.isfinite(p[1]))
    if len(pts) < 3:
        return math.nan
    b = max(range(len(pts)), key=lambda i: pts[i][1])
    if b in (0, len(pts) - 1):
        return math.nan
    (x0, a0), (x1, a1), (x2, a2) = pts[b - 1:b + 2]
    if not x0 < x1 < x2:
        return math.nan
    second = 2.0 * ((a2 - a1) / (x2 - x1) - (a1 - a0) / (x1 - x0)) / (x2 - x0)
    return -second if second < 0 else math.nan


def distinct(starts: list[np.ndarray]) -> list[np.ndarray]:
    """``starts`` without exact repeats, in order."""
    out: list[np.ndarray] = []
    for s in starts:
        if not any(np.array_equal(s, t) for t in out):
            out.append(s)
    return out


def adjusted(prof: ProfileResult) -> float:
    """ℓ + ½ log det cov(b̂): the log-likelihood adjusted for the GLS-estimated means."""
    if prof.beta_cov.size == 0:
        return float(prof.loglik)
    sign, logdet = np.linalg.slogdet(prof.beta_cov)
    return float(prof.loglik + 0.5 * logdet) if sign > 0 else -math.inf


class BudgetSpentError(Exception):
    """A profile would spend more likelihood evaluations than its :attr:`Profiler.max_eval`."""


@dataclass
class Profiler:
    """Adjusted profile likelihood of a fit's log-parameters (and ramp slope) on its record.

    Attributes
    ----------
    par, theta, model, y, z, ll_max : the fit: parameterisation, ϑ̂, state space, record, ℓ̂
    info : observed information −∂²ℓ/∂ϑ² at ϑ̂ (whitening and first steps)
    lo, hi : physical range of each log-parameter (±inf where none)
    zero : zero-boundary parameters → their conditional upper end s
    flat : parameters the information does not determine (searched in their log)
    max_eval : evaluations all profiles may spend (:meth:`afford`; :class:`BudgetSpentError` beyond)
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
    max_eval: float = math.inf
    better: tuple[float, np.ndarray] | None = None  # (ℓ, ϑ) above the fit's maximum, when met

    def __post_init__(self) -> None:
        self.data = em.DataSums.of(self.y, self.z)
        self._zeros = np.where(np.isnan(self.y), np.nan, 0.0)
        self._grad_c: dict[tuple[bool, ...], np.ndarray] = {}
        self._means_free: dict[bytes, tuple[float, float, float, float]] = {}

    @property
    def spent(self) -> bool:
        """Whether the evaluations so far have reached :attr:`max_eval`."""
        return self.n_eval >= self.max_eval

    def afford(self, evaluations: float) -> None:
        """Raise :class:`BudgetSpentError` unless ``evaluations`` more stay within :attr:`max_eval`."""
        if self.n_eval + evaluations > self.max_eval:
            raise BudgetSpentError

    def maximise_cost(self, n_starts: int, base: StateSpace | None = None) -> int:
        """Most evaluations :meth:`maximise` from ``n_starts`` starts can spend."""
        base = base or self.model
        gradient = 0 if tuple(bool(f) for f in base.b_free) in self._grad_c else self.theta.size + 1
        return (n_starts if n_starts > 1 else 0) + gradient + 1 + len(self.zero) + MAX_FUN + 1

    # -- ℓ at one point ------------------------------------------------------------------------------------
    def evaluate(self, theta: np.ndarray, base: StateSpace | None = None) -> tuple[float, float]:
        """(ℓ, ℓ_A) at ϑ with the means of ``base`` (default: the fit's); −inf outside the filter's domain."""
        self.n_eval += 1
        try:
            prof = kalman.loglik(self.par.to_model(theta, base or self.model), self.y, self.z, innovations=False)
        except (ValueError, np.linalg.LinAlgError):  # InputError is a ValueError
            return -math.inf, -math.inf
        return float(prof.loglik), adjusted(prof)

    def held_mean(self, regressor: int, value: float) -> Callable[[np.ndarray], tuple[float, float]]:
        """(ℓ, ℓ_A) at ϑ with the mean of ``regressor`` held at ``value``, from the pass at ϑ with every mean free
        (one per ϑ, its four numbers kept for every value): ℓ is quadratic in the means (GLS), so with β̂, C their
        estimate and covariance ℓ(v) = ℓ̂ − ½(v − β̂_j)²/C_jj, and the other means' covariance given β_j has
        ½ log det = ½(log det C − log C_jj)."""
        name = f"b:{self.model.regressors[regressor]}"

        def at(theta: np.ndarray) -> tuple[float, float]:
            key = theta.tobytes()
            if key not in self._means_free:
                self._means_free[key] = self._means_free_pass(theta, name)
            ll_hat, beta, c_jj, logdet = self._means_free[key]
            if not (c_jj > 0.0 and math.isfinite(logdet)):
                return -math.inf, -math.inf
            ll = ll_hat - 0.5 * (value - beta) ** 2 / c_jj
            return ll, ll + 0.5 * (logdet - math.log(c_jj))

        return at

    def _means_free_pass(self, theta: np.ndarray, name: str) -> tuple[float, float, float, float]:
        """(ℓ̂, β̂ and C of mean ``name``, log det C) at ϑ with every mean free; (−inf, 0, 0, −inf) outside the
        filter's domain or where C is not positive definite."""
        self.n_eval += 1
        try:
            prof = kalman.loglik(self.par.to_model(theta, self.model), self.y, self.z, innovations=False)
        except (ValueError, np.linalg.LinAlgError):  # InputError is a ValueError
            return -math.inf, 0.0, 0.0, -math.inf
        j = prof.names.index(name)
        sign, logdet = np.linalg.slogdet(prof.beta_cov)
        return (float(prof.loglik), float(prof.beta[j]), float(prof.beta_cov[j, j]),
                float(logdet) if sign > 0 else -math.inf)

    def conditional_scale(self, k: int) -> float:
        """Conditional upper 95 % end of a zero-boundary parameter (others held, ℓ down by 1.92), to 10 %: bracketed
        in e²-fold steps up from ϑ̂_k, then bisected in log."""
        th = self.theta.copy()
        inside = float(self.theta[k])
        for step in range(1, int(MAX_LOG_DISTANCE / 2) + 1):
            th[k] = self.theta[k] + 2.0 * step
            if self.ll_max - self.evaluate(th)[0] > mle.LR_DROP_95:
                break
            inside = float(th[k])
        outside = float(th[k])
        while outside - inside > 0.1:
            th[k] = 0.5 * (inside + outside)
            if self.ll_max - self.evaluate(th)[0] > mle.LR_DROP_95:
                outside = float(th[k])
            else:
                inside = float(th[k])
        return float(np.exp(outside))

    # -- the inner maximisation ----------------------------------------------------------------------------
    def fallback_starts(self) -> list[np.ndarray]:
        """Starts besides the trace's extrapolation: :meth:`with_ladder` of the estimate."""
        return self.with_ladder(self.theta)

    def with_ladder(self, theta: np.ndarray) -> list[np.ndarray]:
        """``theta``, and ``theta`` with each zero-boundary parameter at s·e^m for m in :data:`ZERO_LADDER`."""
        out = [theta]
        for j, scale in self.zero.items():
            for m in ZERO_LADDER:
                th = theta.copy()
                th[j] = math.log(scale) + m
                out.append(th)
        return out

    def starts_near(self, theta: np.ndarray) -> list[np.ndarray]:
        """Starts of a profile point whose argmax is predicted at ``theta``: its ladder, then the fallbacks."""
        return [*self.with_ladder(theta), *self.fallback_starts()]

    def adjustment(self, theta: np.ndarray, base: StateSpace) -> float:
        """½ log det cov(b̂) at ϑ: a function of ϑ alone (the regressor columns filtered, the data column zero)."""
        self.n_eval += 1
        try:
            prof = kalman.loglik(self.par.to_model(theta, base), self._zeros, self.z, innovations=False)
        except (ValueError, np.linalg.LinAlgError):  # InputError is a ValueError
            return -math.inf
        return adjusted(prof) - float(prof.loglik)

    def adjustment_gradient(self, base: StateSpace) -> np.ndarray:
        """∂(½ log det cov b̂)/∂ϑ at ϑ̂ (means free as in ``base``), forward differences of 0.05; cached per mask."""
        key = tuple(bool(f) for f in base.b_free)
        if key not in self._grad_c:
            c0 = self.adjustment(self.theta, base)
            grad = np.zeros(self.theta.size)
            for j in range(self.theta.size):
                th = self.theta.copy()
                th[j] += 0.05
                grad[j] = (self.adjustment(th, base) - c0) / 0.05
            self._grad_c[key] = np.where(np.isfinite(grad), grad, 0.0)
        return self._grad_c[key]

    def wald_holds(self, k: int, cov: np.ndarray, a_hat: float, drop_range: tuple[float, float]) -> bool:
        """Whether ℓ_A at both Wald ends of log-parameter k (interior others on the trace
        ϑ̂ + Σ_{·k}/Σ_kk·(ϑ_k − ϑ̂_k), the zero-boundary and undetermined ones re-maximised) lies ``drop_range``
        below ``a_hat``."""
        step = Z95 * cov[:, k] / math.sqrt(cov[k, k])
        step = np.where(np.isfinite(step), step, 0.0)
        loose = set(self.zero) | self.flat
        ladder = [(s, j) for s in self.fallback_starts()[1:] for j in self.zero if s[j] != self.theta[j]]
        self.afford(2 * self.maximise_cost(1 + len(ladder)) if loose else 2)  # two inner maximisations or two points
        for sign in (-1.0, 1.0):
            th = self.theta + sign * step
            if np.any(th < self.lo) or np.any(th > self.hi):
                return False
            if loose:
                starts = [th] + [np.where(np.arange(th.size) == j, s[j], th) for s, j in ladder]
                a = self.maximise(starts, set(range(th.size)) - loose, self.model)[0]
            else:
                a = self.evaluate(th)[1]
            if not drop_range[0] <= a_hat - a <= drop_range[1]:
                return False
        return True

    def best_at_estimate(self) -> float:
        """ℓ_A at the estimate, the zero-boundary and undetermined parameters re-maximised for it."""
        a_hat = self.evaluate(self.theta)[1]
        loose = set(self.zero) | self.flat
        if loose:
            a_hat = max(a_hat, self.maximise(self.fallback_starts(), set(range(self.theta.size)) - loose,
                                             self.model)[0])
        return a_hat

    def maximise(self, starts: list[np.ndarray], fixed: set[int], base: StateSpace, *,
                 score: Callable[[np.ndarray], tuple[float, float]] | None = None) -> tuple[float, np.ndarray]:
        """(ℓ_A at the argmax, argmax) over the log-parameters not in ``fixed`` (held at their start), from the best
        of ``starts``: L-BFGS-B on ℓ plus the adjustment linearised at the start, ℓ_A exact at each point.
        ``score(ϑ)`` → (ℓ, ℓ_A) at ``base``'s means, for the starts and the adjustment (default :meth:`evaluate`;
        :meth:`held_mean` where ``base`` holds a mean)."""
        starts = distinct(starts)
        self.afford(self.maximise_cost(len(starts), base))
        if score is None:
            def adjustment(theta: np.ndarray) -> float:
                # a scored start's pass holds it already (ℓ_A − ℓ does not depend on the data)
                ll, a = next((p for p, t in scored if np.allclose(theta, t, rtol=0.0, atol=1e-12)), (-math.inf, 0.0))
                return a - ll if math.isfinite(ll) else self.adjustment(theta, base)

            def score(theta: np.ndarray) -> tuple[float, float]:
                return self.evaluate(theta, base)
        else:
            def adjustment(theta: np.ndarray) -> float:
                ll, a = score(theta)
                return a - ll if math.isfinite(ll) else -math.inf
        scored = [(score(t), t) for t in starts] if len(starts) > 1 else []
        start = max(scored, key=lambda p: p[0][1])[1] if scored else starts[0]
        free = [j for j in range(self.theta.size) if j not in fixed]
        zero = [j for j in free if j in self.zero]
        flat = [j for j in free if j in self.flat and j not in self.zero]
        inner = [j for j in free if j not in zero and j not in flat]
        T = whitening(self.info[np.ix_(inner, inner)])
        # each zero-boundary coordinate K/s scaled by √(−ℓ_A'') along the scored starts' rungs on it (those that differ
        # from the start there alone) where that exceeds 1: L-BFGS-B's first step, a unit-Hessian one, is then a
        # Newton step there instead of an overshoot (a flatter ℓ_A keeps K/s: its unit step falls short, not beyond)
        scale = np.ones(len(zero))
        for i, j in enumerate(zero):
            others = np.delete(start, j)
            rungs = [(math.exp(t[j]) / self.zero[j], a) for (_, a), t in scored
                     if np.array_equal(np.delete(t, j), others)]
            if (c := rung_curvature(rungs)) > 1.0:
                scale[i] = math.sqrt(c)
        s = np.array([self.zero[j] for j in zero]) / scale
        ni, nz = len(inner), len(zero)
        start = np.where(np.isin(np.arange(start.size), zero), start, np.clip(start, self.lo, self.hi))

        def theta_of(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            th = start.copy()
            raw = start[inner] + T @ x[:ni]
            th[inner] = np.clip(raw, self.lo[inner], self.hi[inner])
            th[zero] = np.clip(np.log(s * x[ni:ni + nz]), self.lo[zero], self.hi[zero])
            th[flat] = np.clip(start[flat] + x[ni + nz:], self.lo[flat], self.hi[flat])
            return th, raw == th[inner]

        x0 = np.concatenate([np.zeros(ni),
                             np.clip(np.exp(start[zero]) / s, ZERO_FLOOR * scale, ZERO_CAP * scale) if nz
                             else np.zeros(0),
                             np.zeros(len(flat))])
        grad_theta = self.adjustment_gradient(base)
        c0 = adjustment(theta_of(x0)[0])
        grad_c = np.concatenate([T.T @ grad_theta[inner], np.zeros(nz), grad_theta[flat]])
        for i in range(ni, ni + nz):
            xp = x0.copy()
            xp[i] += 0.05 * max(x0[i], 0.1)
            grad_c[i] = (adjustment(theta_of(xp)[0]) - c0) / (xp[i] - x0[i])
        grad_c = np.where(np.isfinite(grad_c), grad_c, 0.0)
        best: list = [-math.inf, start, -math.inf]  # ℓ_A, ϑ, ℓ

        def fun(x: np.ndarray) -> tuple[float, np.ndarray]:
            if self.spent:
                raise BudgetSpentError
            th, inside = theta_of(x)
            self.n_eval += 1
            try:
                ll, g, _, prof = mle.loglik_grad_profile(self.par, th, base, self.y, self.z, data=self.data)
            except (ValueError, np.linalg.LinAlgError):  # InputError is a ValueError
                return FAILED_DROP, np.zeros_like(x)
            if not math.isfinite(ll):
                return FAILED_DROP, np.zeros_like(x)
            a = adjusted(prof)
            if a > best[0]:
                best[:] = [a, th, ll]
            grad = np.concatenate([T.T @ (g[inner] * inside), g[zero] / x[ni:ni + nz], g[flat]]) + grad_c
            return self.ll_max - ll - float(grad_c @ (x - x0)), -grad

        bounds = ([(-MAX_WHITENED, MAX_WHITENED)] * ni + [(ZERO_FLOOR * w, ZERO_CAP * w) for w in scale]
                  + [(self.lo[j] - start[j], self.hi[j] - start[j]) for j in flat])
        bounds = [tuple(None if b is None or not math.isfinite(b) else b for b in pair) for pair in bounds]
        if free and math.isfinite(c0):
            minimize(fun, x0, jac=True, method="L-BFGS-B", bounds=bounds,
                     options={"maxiter": 10, "maxfun": MAX_FUN, "ftol": 1e-9, "gtol": 3e-2, "maxcor": 10})
        if not math.isfinite(best[0]):
            ll, a = score(start)
            best[:] = [a, start, ll]
        a, th, ll = best
        if ll > self.ll_max + BETTER_BY and (self.better is None or ll > self.better[0]):
            self.better = (ll, th.copy())
        return a, th

    # -- a log-parameter ------------------------------------------------------------------------------------
    def interval(self, k: int, cov: np.ndarray) -> tuple[float, float]:
        """95 % adjusted-profile interval (lo, hi) of log-parameter k (−inf: 0 not excluded; +inf: unbounded);
        ``cov`` the Wald covariance, whose column k predicts the trace's first points."""
        theta_hat, v_hat = self.theta, float(self.theta[k])
        var = cov[k, k]
        col = cov[:, k] / var if math.isfinite(var) and var > 0 else np.zeros(theta_hat.size)
        col = np.where(np.isfinite(col), col, 0.0)
        col[list(self.zero) + list(self.flat)] = 0.0  # the trace's first guess moves the interior ones only
        se = math.sqrt(var) if math.isfinite(var) and var > 0 else math.inf

        def profile_at(v: float, starts: list[np.ndarray]) -> tuple[float, np.ndarray]:
            starts = [s.copy() for s in starts]
            for s in starts:
                s[k] = v
            return self.maximise(starts, {k}, self.model)

        def predict(step: float) -> list[np.ndarray]:
            return self.starts_near(np.clip(theta_hat + col * step, self.lo, self.hi))

        # its centre's two points and a point at each end, at the least
        self.afford(1 + 4 * self.maximise_cost(len(self.starts_near(theta_hat))))
        room = {d: min(MAX_LOG_DISTANCE, abs(b - v_hat)) if math.isfinite(b) else MAX_LOG_DISTANCE
                for d, b in ((-1.0, self.lo[k]), (1.0, self.hi[k]))}
        a_hat = self.evaluate(theta_hat)[1]
        if k in self.zero:  # ℓ_A along K from 0 up to the conditional scale s, in e-fold steps
            top = math.log(self.zero[k]) - v_hat
            pts = centre(profile_at, v_hat, a_hat, theta_hat, [top - 2.0, top - 1.0, top],
                              predict=predict, parabola=False)
        else:
            half = Z95 * se if se < 5.0 else 1.0
            steps = [-min(half, 0.5 * room[-1.0]), min(half, 0.5 * room[1.0])]
            pts = centre(profile_at, v_hat, a_hat, theta_hat, [s for s in steps if s != 0.0], predict=predict,
                              parabola=True)
        v_c = max(pts, key=lambda p: p[1])[0]
        ends = []
        for direction in (-1.0, 1.0):
            limit = room[direction] + direction * (v_hat - v_c)
            if k in self.zero and direction < 0:  # towards 0: unbounded unless ℓ_A at the estimate is outside
                if a_hat >= max(p[1] for p in pts) - mle.LR_DROP_95:
                    ends.append(-math.inf)
                    continue
                limit = v_c - v_hat
            v_end = end(profile_at, self.starts_near, pts, direction, first=1.0 if se > 5.0 else Z95 * se,
                        limit=limit)
            bound = self.hi[k] if direction > 0 else self.lo[k]
            ends.append(direction * math.inf if math.isfinite(bound) and abs(v_end - bound) < 1e-9 else v_end)
        return ends[0], ends[1]

    # -- the ramp slope -------------------------------------------------------------------------------------
    def slope_interval(self, regressor: int, value: float, se: float) -> tuple[float, float]:
        """95 % adjusted-profile interval [u/s] of the ramp slope (regressor index, GLS value and se); the starts
        scored and the adjustment by :meth:`held_mean` (one pass per ϑ for every slope tried)."""
        fixed = self.model.copy()
        fixed.b_free[regressor] = False

        def base_at(v: float) -> StateSpace:
            base = fixed.copy()
            base.b[regressor] = v
            return base

        def profile_at(v: float, starts: list[np.ndarray]) -> tuple[float, np.ndarray]:
            return self.maximise(starts, set(), base_at(v), score=self.held_mean(regressor, v))

        scale = max(se, 1e-300)
        self.afford(1 + 4 * self.maximise_cost(len(self.fallback_starts()), base_at(value)))
        a_hat = self.held_mean(regressor, value)(self.theta)[1]
        pts = centre(profile_at, value, a_hat, self.theta, [-Z95 * scale, Z95 * scale],
                          predict=lambda _: self.fallback_starts(), parabola=True)
        return (end(profile_at, self.starts_near, pts, -1.0, first=Z95 * scale, limit=1e6 * scale),
                end(profile_at, self.starts_near, pts, 1.0, first=Z95 * scale, limit=1e6 * scale))

