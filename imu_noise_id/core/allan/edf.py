"""Equivalent degrees of freedom (EDF) and χ² intervals of the Allan-family estimators: estimate × edf / variance ~
χ²_edf (NIST SP1065 sec. 5.3), the EDF by the noise type S_y(f) ∝ f^α at that τ: AV, HV, MAV by Greenhall & Riley
(PTTI 2003, eqs. 7–10, tables 1–3; exact sums for J ≤ 100 terms, the asymptotics of cases 1–4 otherwise); TV edf =
b·N/m − c (NIST SP1065 table 11) for α = 0, −1, −2, else the AV's. α from :func:`identify_alpha` unless given."""

from __future__ import annotations

import math

import numpy as np
from scipy import special, stats

from ..errors import InputError

_J_MAX = 100

# Greenhall & Riley 2003, tables 1 (modified, F = 1) and 2 (unmodified, F = m): (a0, a1) by α = 2..−4, d = 1..3.
_TABLE1 = {
    2: ((2 / 3, 1 / 3), (7 / 9, 1 / 2), (22 / 25, 2 / 3)),
    1: ((0.840, 0.345), (0.997, 0.616), (1.141, 0.843)),
    0: ((1.079, 0.368), (1.033, 0.607), (1.184, 0.848)),
    -1: (None, (1.048, 0.534), (1.180, 0.816)),
    -2: (None, (1.302, 0.535), (1.175, 0.777)),
    -3: (None, None, (1.194, 0.703)),
    -4: (None, None, (1.489, 0.702)),
}
_TABLE2 = {
    2: ((3 / 2, 1 / 2), (35 / 18, 1.0), (231 / 100, 3 / 2)),
    1: ((78.6, 25.2), (790.0, 410.0), (9950.0, 6520.0)),
    0: ((2 / 3, 1 / 6), (2 / 3, 1 / 3), (7 / 9, 1 / 2)),
    -1: (None, (0.852, 0.375), (0.997, 0.617)),
    -2: (None, (1.079, 0.368), (1.033, 0.607)),
    -3: (None, None, (1.053, 0.553)),
    -4: (None, None, (1.302, 0.535)),
}
_TABLE3 = {1: (6.0, 4.0), 2: (15.23, 12.0), 3: (47.8, 40.0)}  # α = 1: (b0, b1) by d


def _sw(t: np.ndarray, alpha: int) -> np.ndarray:
    """Greenhall eq. (7): the generalised autocovariance of the phase for S_x ∝ f^(α−2)."""
    t = np.abs(np.asarray(t, dtype=float))
    power = 3 - alpha
    if alpha % 2 == 0:  # |t|^(3−α), negated for α = 2 (the overall sign cancels in the EDF ratio)
        return (-1.0 if alpha == 2 else 1.0) * t**power
    with np.errstate(divide="ignore", invalid="ignore"):
        v = t**power * np.log(t)
    return np.where(t == 0, 0.0, v)


def _sx(t: np.ndarray, F: float, alpha: int) -> np.ndarray:
    """Greenhall eq. (8): phase averaged over 1/F of the sample spacing."""
    if math.isinf(F):
        return _sw(t, alpha + 2)
    return F * F * (2.0 * _sw(t, alpha) - _sw(t - 1.0 / F, alpha) - _sw(t + 1.0 / F, alpha))


def _sz(t: np.ndarray, F: float, alpha: int, d: int) -> np.ndarray:
    """Greenhall eq. (9): autocovariance of the d-th difference, weights (−1)^k C(2d, d+k)."""
    t = np.asarray(t, dtype=float)
    total = np.zeros_like(t)
    for k in range(-d, d + 1):
        total = total + (-1) ** k * special.comb(2 * d, d + k) * _sx(t + k, F, alpha)
    return total


def _basic_sum(J: int, M: float, S: float, F: float, *, alpha: int, d: int) -> float:
    """Greenhall eq. (10)."""
    j = np.arange(1, J)
    return float(
        _sz(0.0, F, alpha, d) ** 2
        + (1.0 - J / M) * _sz(J / S, F, alpha, d) ** 2
        + np.sum(2.0 * (1.0 - j / M) * _sz(j / S, F, alpha, d) ** 2)
    )


def edf_greenhall(
    alpha: int, d: int, m: int, n_phase: int, *, overlapping: bool = True, modified: bool = False
) -> float:
    """EDF of a d-th difference variance (Greenhall & Riley 2003, cases 1–4): S_y ∝ f^``alpha`` (−4..2, with α + 2d >
    1), ``d`` 1, 2 (AV, MAV) or 3 (HV), factor ``m``, ``n_phase`` = N + 1; ``overlapping``: stride 1; ``modified``:
    phase averaged over m."""
    if alpha + 2 * d <= 1:
        raise ValueError(f"Greenhall EDF needs alpha + 2d > 1, got alpha={alpha}, d={d}")
    F = 1.0 if modified else float(m)
    S = float(m) if overlapping else 1.0
    L = m / F + m * d
    M = 1.0 + math.floor(S * (n_phase - L) / m)
    if M < 1:
        raise ValueError(f"m = {m} is too long for {n_phase} phase points")
    J = int(min(M, (d + 1) * S))
    r = M / S
    if modified:  # case 1
        if J <= _J_MAX:
            inv = _basic_sum(J, M, S, 1.0, alpha=alpha, d=d) / (_sz(0.0, 1.0, alpha, d) ** 2 * M)
        elif r > d + 1:
            a0, a1 = _TABLE1[alpha][d - 1]
            inv = (a0 - a1 / r) / r
        else:
            inv = _basic_sum(_J_MAX, _J_MAX, _J_MAX / r, 1.0, alpha=alpha, d=d)
            inv /= _sz(0.0, 1.0, alpha, d) ** 2 * _J_MAX
        return 1.0 / float(inv)
    if alpha <= 0:  # case 2
        if J <= _J_MAX:
            Fp = float(m) if m * (d + 1) <= _J_MAX else math.inf
            inv = _basic_sum(J, M, S, Fp, alpha=alpha, d=d) / (_sz(0.0, Fp, alpha, d) ** 2 * M)
        elif r > d + 1:
            a0, a1 = _TABLE2[alpha][d - 1]
            inv = (a0 - a1 / r) / r
        else:
            inv = _basic_sum(_J_MAX, _J_MAX, _J_MAX / r, math.inf, alpha=alpha, d=d) / (
                _sz(0.0, math.inf, alpha, d) ** 2 * _J_MAX
            )
        return 1.0 / float(inv)
    if alpha == 1:  # case 3
        if J <= _J_MAX:
            inv = _basic_sum(J, M, S, float(m), alpha=1, d=d) / (_sz(0.0, float(m), 1, d) ** 2 * M)
        elif r > d + 1:
            a0, a1 = _TABLE2[1][d - 1]
            b0, b1 = _TABLE3[d]
            inv = (a0 - a1 / r) / ((b0 + b1 * math.log(m)) ** 2 * r)
        else:
            b0, b1 = _TABLE3[d]
            mp = _J_MAX / r
            inv = _basic_sum(_J_MAX, _J_MAX, mp, mp, alpha=1, d=d) / ((b0 + b1 * math.log(m)) ** 2 * _J_MAX)
        return 1.0 / float(inv)
    # case 4, α = 2 (white phase noise, i.e. quantisation of an integrating sensor)
    if math.ceil(r) > d:
        a0 = special.comb(4 * d, 2 * d) / special.comb(2 * d, d) ** 2
        return 1.0 / float((a0 - (d / 2.0) / r) / M)
    # Very few differences: the exact sum (Greenhall eq. 10) with the true filter (F = m).
    return 1.0 / float(_basic_sum(J, M, S, float(m), alpha=2, d=d) / (_sz(0.0, float(m), 2, d) ** 2 * M))


_TOTVAR_BC = {0: (1.50, 0.0), -1: (1.17, 0.22), -2: (0.93, 0.36)}  # NIST SP1065 table 11


def edf_total(alpha: int, m: int, n: int) -> float:
    """EDF of the TV at τ = m·dt from n samples: b·n/m − c (NIST SP1065 table 11); α = 1, 2: the overlapping AV's."""
    if alpha in _TOTVAR_BC:
        b, c = _TOTVAR_BC[alpha]
        return b * n / m - c
    return edf_greenhall(alpha, 2, m, n + 1, overlapping=True)


def edf_of(kind: str, alpha: int, m: int, n: int) -> float:
    if kind == "total":
        return edf_total(alpha, m, n)
    d = 3 if kind == "hadamard" else 2
    return edf_greenhall(alpha, d, m, n + 1, overlapping=True, modified=kind == "modified")


def alpha_range(kind: str) -> tuple[int, int]:
    return (-4, 2) if kind == "hadamard" else (-2, 2)


#: Half-width (in τ points) of the local log-log slope regression.
SLOPE_HALF_WINDOW = 2


def local_slopes(tau: np.ndarray, variance: np.ndarray, half_window: int = SLOPE_HALF_WINDOW) -> np.ndarray:
    """Least-squares slope of log σ² on log τ over ±``half_window`` τ per column; NaN with fewer than two positive
    values."""
    v = np.asarray(variance, dtype=float)
    v2 = v[:, None] if v.ndim == 1 else v
    lt = np.log(np.asarray(tau, dtype=float))
    with np.errstate(divide="ignore", invalid="ignore"):
        lv = np.log(np.where(v2 > 0, v2, np.nan))
    mu = np.full(v2.shape, np.nan)
    for i in range(lt.size):
        sl = slice(max(0, i - half_window), min(lt.size, i + half_window + 1))
        for j in range(v2.shape[1]):
            y = lv[sl, j]
            ok = np.isfinite(y)
            if ok.sum() >= 2:
                x = lt[sl][ok]
                xc = x - x.mean()
                mu[i, j] = float(np.dot(xc, y[ok] - y[ok].mean()) / np.dot(xc, xc))
    return mu[:, 0] if v.ndim == 1 else mu


#: Local AV slope below which the noise type is read from the lag-1 autocorrelation when the data are at hand
#: (between white frequency noise, μ = −1, and phase noise, μ = −2).
STEEP_SLOPE = -1.25


def identify_alpha(tau: np.ndarray, variance: np.ndarray, kind: str, y: np.ndarray | None = None,
                   m: np.ndarray | None = None) -> np.ndarray:
    """α per τ and axis: −μ − 1 rounded (μ: :func:`local_slopes`), clipped; where μ < :data:`STEEP_SLOPE` and ``y``,
    ``m`` given, :func:`lag1_alpha` once per run; non-increasing in τ."""
    variance = np.asarray(variance, dtype=float)
    lo, hi = alpha_range(kind)
    if tau.size < 2:
        return np.zeros(variance.shape, dtype=int)
    mu = local_slopes(tau, variance)
    mu = np.where(np.isfinite(mu), mu, -1.0)
    alpha = np.rint(-mu - 1.0)
    if kind != "modified":
        alpha = np.where(mu <= -1.5, 2.0, alpha)
        if y is not None and m is not None:
            y2 = y[:, None] if y.ndim == 1 else y
            mu2 = mu[:, None] if mu.ndim == 1 else mu
            a2 = alpha[:, None] if alpha.ndim == 1 else alpha
            for j in range(mu2.shape[1]):
                # one estimate per run of steep τ, at its shortest τ (why: docs/analysis.md, intervals)
                steep = mu2[:, j] < STEEP_SLOPE
                starts = np.flatnonzero(steep & ~np.concatenate([[False], steep[:-1]]))
                for i0 in starts:
                    run = i0 + np.flatnonzero(np.cumprod(steep[i0:]))
                    est = lag1_alpha(y2[:, j], int(m[i0]))
                    if est is not None:
                        a2[run, j] = float(np.rint(est))
    alpha = np.minimum.accumulate(np.clip(alpha, lo, hi), axis=0)
    return alpha.astype(int)


#: Fewest averages the lag-1 autocorrelation needs.
LAG1_MIN_POINTS = 30


def lag1_alpha(y: np.ndarray, m: int, d_max: int = 2) -> float | None:
    """α at factor m from the lag-1 autocorrelation of the m-averages (Riley & Greenhall 2004): α = −2(δ + d), δ =
    r₁/(1 + r₁) < 0.25 after d differences; None below :data:`LAG1_MIN_POINTS` averages."""
    k = y.size // m
    if k < LAG1_MIN_POINTS:
        return None
    z = y[: k * m].reshape(k, m).mean(axis=1)
    t = np.arange(k, dtype=float)
    z = z - np.polyval(np.polyfit(t, z, 1), t)
    for d in range(d_max + 1):
        zc = z - z.mean()
        denom = float(zc @ zc)
        if denom <= 0:
            return None
        r1 = float(zc[:-1] @ zc[1:]) / denom
        delta = r1 / (1.0 + r1)
        if delta < 0.25 or d == d_max:
            return -2.0 * (delta + d)
        z = np.diff(z)
    return None


def chi2_interval(variance: np.ndarray, edf: np.ndarray, confidence: float) -> tuple[np.ndarray, np.ndarray]:
    """Two-sided χ² interval [edf·σ̂²/χ²_{(1+c)/2}(edf), edf·σ̂²/χ²_{(1−c)/2}(edf)] (NIST SP1065 eq. 45)."""
    if not 0.0 < confidence < 1.0:
        raise InputError(f"confidence must lie in (0, 1), got {confidence!r}")
    hi_q = stats.chi2.ppf(0.5 + confidence / 2.0, edf)
    lo_q = stats.chi2.ppf(0.5 - confidence / 2.0, edf)
    return variance * edf / hi_q, variance * edf / lo_q
