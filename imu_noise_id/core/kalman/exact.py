"""Exact Kalman filter and RTS smoother with lag-one covariance (paper 000 appendix): any Σ, NaN missing."""

from __future__ import annotations

import numpy as np

from .common import LOG_2PI, Columns, DisturbanceSums, InnovationResult, SmootherStats, StateSums
from .statespace import StateSpace


def _forward(model: StateSpace, cols: Columns):
    phi, q, h, r = model.phi, model.q, model.h, float(model.r)
    m, n = cols.y.shape
    ycols = cols.y.T
    p = model.n_states
    observed = ~np.isnan(ycols[:, 0])
    xp = np.empty((n, p, m))
    xf = np.empty((n, p, m))
    Pp = np.empty((n, p, p))
    Pf = np.empty((n, p, p))
    K = np.zeros((n, p))
    e = np.full((n, m), np.nan)
    f = np.full(n, np.nan)
    x = cols.m0.copy()
    P = np.array(model.initial_covariance(), dtype=float)
    for t in range(n):
        xp[t], Pp[t] = x, P
        if observed[t]:
            Ph = P @ h
            ft = float(h @ Ph) + r
            k = Ph / ft
            et = ycols[t] - h @ x
            x = x + np.outer(k, et)
            P = P - np.outer(k, Ph)
            P = 0.5 * (P + P.T)
            e[t], f[t], K[t] = et, ft, k
        xf[t], Pf[t] = x, P
        x = phi @ x + cols.g
        P = phi @ P @ phi.T + q
    return xp, xf, Pp, Pf, K, InnovationResult(e.T.copy(), f, observed)


def innovations(model: StateSpace, cols: Columns) -> InnovationResult:
    """Innovations e_t = y_t − H x_t^{t−1} of every column and their variance F_t = H P_t^{t−1} Hᵀ + R."""
    return _forward(model, cols)[-1]


def smooth(model: StateSpace, cols: Columns, y: np.ndarray, z: np.ndarray, *,
           moments: bool = True) -> SmootherStats:
    """E-step statistics of the data column (its means' sums against the data y (N,) and regressors z (N, k):
    :class:`~.common.StateSums`, the p × p sums with ``moments``): RTS smoother and lag-one covariance (paper 000
    appendix), t = N … 2::

        J_{t−1} = P_{t−1}^{t−1} Φᵀ (P_t^{t−1})⁻¹
        x_{t−1}^N = x_{t−1}^{t−1} + J_{t−1}(x_t^N − x_t^{t−1})
        P_{t−1}^N = P_{t−1}^{t−1} + J_{t−1}(P_t^N − P_t^{t−1})J_{t−1}ᵀ
        P_{N,N−1}^N = (I − K_N H) Φ P_{N−1}^{N−1}
        P_{t−1,t−2}^N = P_{t−1}^{t−1} J_{t−2}ᵀ + J_{t−1}(P_{t,t−1}^N − Φ P_{t−1}^{t−1}) J_{t−2}ᵀ
    """
    phi, h = model.phi, model.h
    data_only = Columns(cols.y[:1], cols.g[:, :1], cols.m0[:, :1], cols.names[:1], cols.omega[:1])
    xp, xf, Pp, Pf, K, inn = _forward(model, data_only)
    n, p = xp.shape[0], xp.shape[1]
    xp, xf = xp[:, :, 0], xf[:, :, 0]
    xs = np.empty((n, p))
    xs[-1] = xf[-1]
    Ps = Pf[-1].copy()
    obs = inn.observed
    sum_p = Ps.copy()
    sum_p_obs = Ps.copy() if obs[-1] else np.zeros((p, p))
    J = np.empty((n, p, p))
    adjoint = _Adjoint(phi, h, p)
    for t in range(n - 1, 0, -1):
        J[t - 1] = np.linalg.solve(Pp[t].T, (Pf[t - 1] @ phi.T).T).T
        xs[t - 1] = xf[t - 1] + J[t - 1] @ (xs[t] - xp[t])
        adjoint.step(inn.e[0, t], inn.f[t], K[t], observed=obs[t], x=xs[t - 1], p_filt=Pf[t - 1])
        Ps = Pf[t - 1] + J[t - 1] @ (Ps - Pp[t]) @ J[t - 1].T
        Ps = 0.5 * (Ps + Ps.T)
        sum_p += Ps
        if obs[t - 1]:
            sum_p_obs += Ps
    p_first = Ps
    sum_lag = np.zeros((p, p))
    if n > 1:
        lag = (np.eye(p) - np.outer(K[-1], h)) @ phi @ Pf[-2]
        sum_lag += lag
        for t in range(n - 1, 1, -1):  # 0-based t: lag(t) = P_{t,t-1} → lag(t-1) = P_{t-1,t-2}
            lag = Pf[t - 1] @ J[t - 2].T + J[t - 1] @ (lag - phi @ Pf[t - 1]) @ J[t - 2].T
            sum_lag += lag
    fo = inn.f[obs]
    eo = inn.e[0, obs]
    loglik = -0.5 * float(np.sum(LOG_2PI + np.log(fo) + eo * eo / fo))
    states = StateSums.of(np.ascontiguousarray(xs.T), y=y, z=z, d=cols.y[0], h=h, observed=obs, moments=moments)
    return SmootherStats(states, sum_p, p_first, Pf[-1].copy(), sum_lag, sum_p_obs, loglik, obs, adjoint.sums())


class _Adjoint:
    """The smoother's adjoint backwards in time and its sums (:class:`~.common.DisturbanceSums`; Durbin & Koopman 2012,
    eqs. 4.38, 4.42): r_{t−1} = Hᵀ e_t / F_t + L_tᵀ r_t, N_{t−1} = Hᵀ H / F_t + L_tᵀ N_t L_t with L_t = Φ(I − K_t H)
    at an observed sample, r_{t−1} = Φᵀ r_t, N_{t−1} = Φᵀ N_t Φ at a missing one; r_{N−1} = 0, N_{N−1} = 0."""

    def __init__(self, phi: np.ndarray, h: np.ndarray, p: int) -> None:
        self.phi, self.h = phi, h
        self.r, self.n_t = np.zeros(p), np.zeros((p, p))
        self.rr, self.rx, self.n, self.nlp = (np.zeros((p, p)) for _ in range(4))

    def step(self, e: float, f: float, k: np.ndarray, *, observed: bool, x: np.ndarray, p_filt: np.ndarray) -> None:
        """From r_t, N_t to r_{t−1}, N_{t−1} with sample t's innovation ``e``, its variance ``f`` and filter gain
        ``k``; adds disturbance t − 1's terms, its smoothed state ``x`` = x_{t−1}^N and ``p_filt`` = P_{t−1}^{t−1}."""
        if observed:
            L = self.phi - np.outer(self.phi @ k, self.h)
            self.r = self.h * (e / f) + L.T @ self.r
            self.n_t = np.outer(self.h, self.h) / f + L.T @ self.n_t @ L
        else:
            self.r = self.phi.T @ self.r
            self.n_t = self.phi.T @ self.n_t @ self.phi
        self.rr += np.outer(self.r, self.r)
        self.rx += np.outer(self.r, x)
        self.n += self.n_t
        self.nlp += self.n_t @ self.phi @ p_filt

    def sums(self) -> DisturbanceSums:
        """The sums over the disturbances stepped through."""
        return DisturbanceSums(self.rr, self.rx, 0.5 * (self.n + self.n.T), self.nlp)
