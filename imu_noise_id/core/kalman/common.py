"""Kalman engines' inputs, results and GLS profile: column 0 the data, the others responses to b, u, μ (docs/em.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .statespace import StateSpace

LOG_2PI = math.log(2.0 * math.pi)


@dataclass
class Columns:
    """Inputs of a multi-column run: ``y`` (m, N) measurement input (NaN in y[0]: missing), ``g``, ``m0`` (p, m)
    state input and initial mean, ``names`` (``'data'``, ``'b:<regressor>'``, ``'u:<state>'``, ``'mu:<state>'``),
    ``omega`` (m,) ω [rad/sample] of sinusoidal columns (NaN otherwise)."""

    y: np.ndarray
    g: np.ndarray
    m0: np.ndarray
    names: list[str]
    omega: np.ndarray


@dataclass
class InnovationResult:
    """Innovations of each column and their variance."""

    e: np.ndarray  # (m, N); NaN where missing
    f: np.ndarray  # (N,); NaN where missing
    observed: np.ndarray  # (N,) bool
    constant_f: bool = False  # F_t is the same at every t (steady engine)


@dataclass(frozen=True)
class DisturbanceSums:
    """Sums over the state disturbances η_t = x_{t+1} − Φ x_t − u, t = 1 … N − 1, of the smoother's adjoint r_t
    (E[η_t | y] = Q r_t) and its variance N_t (Durbin & Koopman 2012, eqs. 4.38, 4.42, 4.69; Koopman & Shephard 1992):
    ``rr`` Σ r_t r_tᵀ, ``rx`` Σ r_t (x_t^N)ᵀ, ``n`` Σ N_t and ``nlp`` Σ N_t L_t P_t (L_t = Φ(I − K_t H), P_t the
    predicted covariance; L_t P_t = Φ P_t^t). The score in Φ and Q is then Σ r_t (x_t^N)ᵀ − Σ N_t L_t P_t and
    ½ Σ (r_t r_tᵀ − N_t), with no difference of terms of the states' size (docs/em.md, "The score from the
    disturbance smoother")."""

    rr: np.ndarray
    rx: np.ndarray
    n: np.ndarray
    nlp: np.ndarray

    @classmethod
    def none(cls, p: int) -> DisturbanceSums:
        """The empty sums of a record of one sample (no disturbance) with ``p`` states."""
        zero = np.zeros((p, p))
        return cls(zero, zero.copy(), zero.copy(), zero.copy())


@dataclass(frozen=True)
class StateSums:
    """Sums over the smoothed means x_t^N (t = 0 … N − 1) that the M-step and the score use (paper 000 §3.3), in place
    of the p × N means themselves: ``gram`` Σ x_t x_tᵀ, ``gram_obs`` the same over the observed samples, ``lag``
    Σ_{t≥1} x_t x_{t−1}ᵀ (these three None where only the score's sums were asked for: O(p²N) that the score does not
    use), ``total`` Σ x_t, ``first`` x_0, ``last`` x_{N−1}, ``y_cross`` Σ_obs y_t x_t (p,), ``z_cross`` Σ_obs z_t x_tᵀ
    (k, p) and ``residual_sse`` Σ_obs (d_t − H x_t)², d = y − z b the column the smoother ran on (the data at the
    model's regression coefficients)."""

    gram: np.ndarray | None
    gram_obs: np.ndarray | None
    lag: np.ndarray | None
    total: np.ndarray
    first: np.ndarray
    last: np.ndarray
    y_cross: np.ndarray
    z_cross: np.ndarray
    residual_sse: float

    @classmethod
    def of(cls, xs: np.ndarray, *, y: np.ndarray, z: np.ndarray, d: np.ndarray, h: np.ndarray,
           observed: np.ndarray | None = None, moments: bool = True) -> StateSums:
        """The sums of the means ``xs`` (p, L) of one span of samples: the data y (L,), regressors z (L, k), the
        column d (L,) the smoother ran on, H (p,); ``observed`` (L,) bool, None where every sample is; ``moments``:
        the p × p sums too."""
        p = xs.shape[0]
        if observed is None:
            xo, yo, zo, do = xs, y, z, d
        else:
            xo, yo, zo, do = xs[:, observed], y[observed], z[observed], d[observed]
        gram = gram_obs = lag = None
        if moments:
            gram = xs @ xs.T
            gram_obs = gram if observed is None else xo @ xo.T
            lag = xs[:, 1:] @ xs[:, :-1].T
        residual = do - h @ xo
        first, last = (xs[:, 0].copy(), xs[:, -1].copy()) if xs.shape[1] else (np.zeros(p), np.zeros(p))
        return cls(gram, gram_obs, lag, xs.sum(axis=1), first, last, xo @ yo, zo.T @ xo.T, float(residual @ residual))

    @classmethod
    def joined(cls, earlier: StateSums, later: StateSums) -> StateSums:
        """The sums over two adjacent spans, ``earlier`` ending where ``later`` begins (the lag term across the seam
        x_first(later) x_last(earlier)ᵀ added)."""
        moments = earlier.gram is not None and later.gram is not None
        return cls(earlier.gram + later.gram if moments else None,
                   earlier.gram_obs + later.gram_obs if moments else None,
                   earlier.lag + later.lag + np.outer(later.first, earlier.last) if moments else None,
                   earlier.total + later.total, earlier.first, later.last, earlier.y_cross + later.y_cross,
                   earlier.z_cross + later.z_cross, earlier.residual_sse + later.residual_sse)


@dataclass
class SmootherStats:
    """M-step inputs (paper 000 §3.3, appendix): ``states`` the sums of x_t^N (:class:`StateSums`), ``sum_p``
    Σ P_t^N, ``p_first``, ``p_last``, ``sum_lag`` Σ P_{t,t−1}^N, ``sum_p_obs``, ``loglik``, ``observed``;
    ``disturbances`` the adjoint's sums for the score (:class:`DisturbanceSums`)."""

    states: StateSums
    sum_p: np.ndarray
    p_first: np.ndarray
    p_last: np.ndarray
    sum_lag: np.ndarray
    sum_p_obs: np.ndarray
    loglik: float
    observed: np.ndarray
    disturbances: DisturbanceSums


def check_data(y: np.ndarray, z: np.ndarray | None, n_regressors: int) -> tuple[np.ndarray, np.ndarray]:
    """Validated y (N,) (NaN: missing) and Z (N, k); InputError on inf or a bad shape."""
    y = np.asarray(y, dtype=float).ravel()
    if not math.isfinite(float(np.sum(y))) and np.any(np.isinf(y)):  # a finite sum: no inf (nor NaN) in y
        raise InputError("the signal contains infinite values; remove them or mark them as NaN (missing)")
    if z is None:
        z = np.zeros((y.size, 0))
    z = np.asarray(z, dtype=float)
    if z.ndim == 1:
        z = z[:, None]
    if z.shape != (y.size, n_regressors):
        raise InputError(f"regressors must have shape ({y.size}, {n_regressors}), got {z.shape}")
    if not math.isfinite(float(np.sum(z))) and not np.all(np.isfinite(z)):  # a finite sum: every entry finite
        raise InputError("regressors (exog) must be finite everywhere, also where the signal is missing")
    return y, z


def build_columns(model: StateSpace, y: np.ndarray, z: np.ndarray, profile: bool) -> Columns:
    """Column 0 = data at the model's current mean parameters; with ``profile`` one column per free one."""
    p = model.n_states
    free_b = np.flatnonzero(model.b_free) if profile else np.zeros(0, int)
    free_u = np.flatnonzero(model.u_free) if profile else np.zeros(0, int)
    free_mu = np.flatnonzero(model.mu_free) if profile else np.zeros(0, int)
    b_fixed = np.where(model.b_free, 0.0, model.b) if profile else model.b
    u0 = np.where(model.u_free, 0.0, model.u) if profile else model.u
    mu0 = np.where(model.mu_free, 0.0, model.mu) if profile else model.mu
    m = 1 + free_b.size + free_u.size + free_mu.size
    ycols = np.empty((m, y.size))
    if z.shape[1] and np.any(b_fixed):
        np.subtract(y, z @ b_fixed, out=ycols[0])
    else:
        ycols[0] = y
    ycols[1 + free_b.size:] = 0.0
    g, m0 = np.zeros((p, m)), np.zeros((p, m))
    g[:, 0], m0[:, 0] = u0, mu0
    names = ["data"]
    omega = np.full(m, np.nan)
    declared = model.sinusoid_omega or (math.nan,) * model.n_regressors
    c = 1
    for j in free_b:
        np.negative(z[:, j], out=ycols[c])
        names.append(f"b:{model.regressors[j]}")
        omega[c] = declared[j]
        c += 1
    for j in free_u:
        g[j, c] = 1.0
        names.append(f"u:{j}")
        c += 1
    for j in free_mu:
        m0[j, c] = 1.0
        names.append(f"mu:{j}")
        c += 1
    return Columns(ycols, g, m0, names, omega)


@dataclass
class ProfileResult:
    """Log-likelihood with the free mean parameters at their GLS estimate (or as given)."""

    loglik: float
    beta: np.ndarray  # GLS estimates of the free mean parameters, in Columns.names[1:] order
    beta_cov: np.ndarray  # their covariance (inverse of the GLS normal matrix)
    names: list[str]
    innovations: np.ndarray  # (N,) innovations at beta (NaN where missing)
    variances: np.ndarray  # (N,)


#: Up to this many columns :func:`gram` takes one dot product per pair: OpenBLAS's product of a few long rows with
#: their transpose takes 2–3 times as long (0.6 vs 1.6 ms for two rows of 360k samples, 1.6 vs 3.8 ms for three).
GRAM_BY_ROWS = 4


def gram(rows: np.ndarray) -> np.ndarray:
    """rows·rowsᵀ (m, m) of ``rows`` (m, N)."""
    m = rows.shape[0]
    if m > GRAM_BY_ROWS:
        return rows @ rows.T
    out = np.empty((m, m))
    for i in range(m):
        for j in range(i, m):
            out[i, j] = out[j, i] = rows[i] @ rows[j]
    return out


def profile(inn: InnovationResult, names: list[str], keep_innovations: bool = True) -> ProfileResult:
    """GLS β̂ minimising Σ_t e_t(β)²/F_t, e(β) = e₀ + Σ_c β_c r_c, and the exact Gaussian log-likelihood there.
    InputError where the innovations' sums of squares overflow (a maximisation's trial point far out, which it then
    reads as a point it cannot evaluate, as it reads the smoother's overflowing covariance sums)."""
    obs = inn.observed
    all_obs = bool(np.all(obs))
    E = inn.e if all_obs else inn.e[:, obs]
    k = E.shape[0] - 1
    with np.errstate(over="ignore", invalid="ignore"):  # not finite: refused below
        if inn.constant_f:
            f0 = float(inn.f[0])
            G = gram(E) / f0
            sum_log_f = E.shape[1] * np.log(f0)
        else:
            f = inn.f if all_obs else inn.f[obs]
            Ew = E / np.sqrt(f)
            G = gram(Ew)
            sum_log_f = float(np.sum(np.log(f)))
    if not np.all(np.isfinite(G)):
        raise InputError("the innovations' sums of squares overflow: the model cannot be evaluated at these "
                         "parameters (its variances are too far apart)")
    if k:
        try:
            cov = np.linalg.inv(G[1:, 1:])
        except np.linalg.LinAlgError:
            raise InputError("the regressors are collinear (e.g. a constant exog column besides the bias)") from None
        beta = -cov @ G[1:, 0]
        quad = float(G[0, 0] + beta @ G[1:, 0])
    else:
        beta, cov = np.zeros(0), np.zeros((0, 0))
        quad = float(G[0, 0])
    ll = -0.5 * (E.shape[1] * LOG_2PI + sum_log_f + quad)
    e_full = (inn.e[0] + beta @ inn.e[1:]) if keep_innovations else np.zeros(0)
    return ProfileResult(ll, beta, cov, names[1:], e_full, inn.f)


def apply_beta(model: StateSpace, result: ProfileResult) -> StateSpace:
    """A copy of ``model`` with its free mean parameters set to the GLS estimates."""
    out = model.copy()
    for name, value in zip(result.names, result.beta, strict=True):
        kind, _, key = name.partition(":")
        if kind == "b":
            out.b[model.regressors.index(key)] = value
        elif kind == "u":
            out.u[int(key)] = value
        else:
            out.mu[int(key)] = value
    return out
