"""Allan-family variances of rate signals (gyro rad/s, accel m/s²) with χ² confidence intervals.

Four estimators over τ = m·dt (m a positive integer), each vectorised over the axes of an (N,) or (N, k)
array of *rate* samples y (``data_type="freq"`` in frequency-stability terms):

* ``"allan"``: maximal-overlap Allan variance, paper 000 (Stebler et al. 2011) eq. (2);
* ``"hadamard"``: overlapping Hadamard variance, paper 000 section 2 (the estimator below eq. 2 with
  N − 3τ + 1 terms);
* ``"total"``: total variance, paper 000 section 2 (TV). The paper's formula is only sketched there (circular
  shifts); we implement the standard form it cites ([28], Howe; NIST SP1065 eq. 25): the phase series is
  extended by odd reflection at both ends and all N − 2 interior second differences are averaged;
* ``"modified"``: modified Allan variance (NIST SP1065 eq. 14), not in paper 000: it averages the phase over
  m samples before differencing and separates white from flicker phase noise.

With the phase (integrated rate) x_0 = 0, x_i = dt·Σ_{j<i} (y_j − ȳ), i = 0..N, the estimators are

* AV(m)   = Σ_i (x_{i+2m} − 2x_{i+m} + x_i)² / (2 τ² (N − 2m + 1))                       (paper 000 eq. 2)
* HV(m)   = Σ_i (x_{i+3m} − 3x_{i+2m} + 3x_{i+m} − x_i)² / (6 τ² (N − 3m + 1))
* TV(m)   = Σ_{i=1}^{N−1} (x*_{i−m} − 2x_i + x*_{i+m})² / (2 τ² (N − 1)),
  x*_{−j} = 2x_0 − x_j, x*_{N+j} = 2x_N − x_{N−j}
* MAV(m)  = Σ_j (Σ_{i=j}^{j+m−1} x_{i+2m} − 2x_{i+m} + x_i)² / (2 m² τ² (N − 3m + 2))

Each costs O(N) per τ (lagged differences of the phase, and a moving sum through a cumulative sum for MAV);
the mean is removed before integrating so that the phase stays small and the differences keep their precision.
These are the definitions allantools uses (``oadev``, ``ohdev``, ``totdev``, ``mdev`` with
``data_type="freq"``); the tests check equality to a relative 1e-9.

Confidence intervals
--------------------
The estimate times ``edf / variance`` is treated as χ² with ``edf`` equivalent degrees of freedom
(NIST SP1065 section 5.3), giving the two-sided interval [edf·σ̂²/χ²_{(1+c)/2}, edf·σ̂²/χ²_{(1−c)/2}].
The EDF depends on the power-law noise type S_y(f) ∝ f^α at that τ:

* AV, HV, MAV: Greenhall's general EDF algorithm (C. A. Greenhall, W. J. Riley, "Uncertainty of stability
  variances based on finite differences", PTTI 2003, eqs. 7–10 and tables 1–3), d = 2 (AV, MAV) or 3 (HV),
  F = m (unmodified) or 1 (modified), S = m (overlapping). Exact sums are used when J ≤ 100 terms, the paper's
  asymptotic table formulas otherwise (its cases 1–4).
* TV: Howe's empirical fit edf = b·N/m − c (NIST SP1065 table 11) for α = 0, −1, −2; for α = 1, 2, where that
  table has no entry, the overlapping-AV EDF from Greenhall's algorithm (TV is never worse than the AV it
  improves on, so this errs on the wide side).

The noise type is an **assumption**. By default it is identified per τ and axis from the local log-log slope
μ of the estimated variance (σ² ∝ τ^μ): α = −μ − 1 rounded to an integer, which maps white noise (μ = −1) to
α = 0, random walk (μ = +1) to α = −2, and quantisation noise (μ = −2, or −3 for MAV) to α = 2; α is clipped
to the range the EDF formulas cover (−2..2; −4..2 for HV). Pass ``alpha=`` to fix it instead. Deterministic
effects (a rate ramp, μ = +2) are not noise: their interval is only indicative.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy import special, stats

from .errors import InputError

Kind = Literal["allan", "hadamard", "total", "modified"]
KINDS: tuple[str, ...] = ("allan", "hadamard", "total", "modified")

#: Default number of averaging times per decade of τ.
DEFAULT_PER_DECADE = 8
#: Default two-sided confidence level of the intervals.
DEFAULT_CONFIDENCE = 0.95


@dataclass(frozen=True)
class AllanResult:
    """One Allan-family variance of k axes over T averaging times.

    Attributes
    ----------
    kind : {"allan", "hadamard", "total", "modified"}
        The estimator.
    dt : float
        Sampling period [s].
    n : int
        Number of samples per axis the estimate used.
    m : ndarray of int, shape (T,)
        Averaging factors, τ = m·dt.
    tau : ndarray, shape (T,)
        Averaging times [s].
    variance : ndarray, shape (T, k)
        The variance estimate [u²] (u = rad/s or m/s²).
    ci_low, ci_high : ndarray, shape (T, k)
        Two-sided ``confidence`` interval of the variance from the χ² law with ``edf`` degrees of freedom.
    edf : ndarray, shape (T, k)
        Equivalent degrees of freedom.
    alpha : ndarray of int, shape (T, k)
        Power-law noise exponent (S_y ∝ f^α) assumed for the EDF.
    confidence : float
        Confidence level of ``ci_low``/``ci_high``.
    """

    kind: str
    dt: float
    n: int
    m: np.ndarray
    tau: np.ndarray
    variance: np.ndarray
    ci_low: np.ndarray
    ci_high: np.ndarray
    edf: np.ndarray
    alpha: np.ndarray
    confidence: float

    @property
    def deviation(self) -> np.ndarray:
        """Square root of :attr:`variance` [u]."""
        return np.sqrt(self.variance)


# --------------------------------------------------------------------------------------------------- τ grid
def max_m(n: int, kind: Kind) -> int:
    """Largest averaging factor m the estimator ``kind`` defines for n samples (0 if none).

    AV needs at least two second differences (m ≤ (n − 1)/2), HV two third differences (m ≤ (n − 1)/3),
    MAV two phase-averaged differences (m ≤ n/3); TV is limited to τ ≤ T/2 as in NIST SP1065.
    """
    _check_kind(kind)
    if kind == "hadamard":
        return max((n - 1) // 3, 0)
    if kind == "modified":
        return max(n // 3, 0)
    return max((n - 1) // 2, 0)


def choose_m(
    n: int, kind: Kind = "allan", per_decade: int = DEFAULT_PER_DECADE, m_max: int | None = None
) -> np.ndarray:
    """Log-spaced unique averaging factors 1 ≤ m ≤ ``m_max`` (default :func:`max_m`), ~``per_decade`` a decade.

    The grid is 10^(j/per_decade) rounded to integers and de-duplicated, plus the largest allowed m so that
    the longest τ the data supports is always shown.

    Raises
    ------
    InputError
        If the series is too short for even m = 1, or ``per_decade`` < 1.
    """
    limit = max_m(n, kind)
    if limit < 1:
        raise InputError(f"{n} samples are too few for the {kind} variance: need at least {_min_samples(kind)}")
    if m_max is not None:
        limit = min(limit, int(m_max))
        if limit < 1:
            raise InputError(f"m_max must be >= 1, got {m_max}")
    if per_decade < 1:
        raise InputError(f"per_decade must be >= 1, got {per_decade}")
    exps = np.arange(0, math.floor(math.log10(limit) * per_decade) + 1) / per_decade
    m = np.unique(np.round(10.0**exps).astype(np.int64))
    m = m[m <= limit]
    if m[-1] != limit:
        m = np.append(m, limit)
    return m


def _min_samples(kind: Kind) -> int:
    return {"allan": 3, "hadamard": 4, "total": 3, "modified": 3}[kind]


def _check_kind(kind: str) -> None:
    if kind not in KINDS:
        raise InputError(f"unknown variance kind {kind!r}: use one of {', '.join(KINDS)}")


def _resolve_m(n: int, dt: float, kind: Kind, *, tau, m, per_decade: int) -> np.ndarray:
    if tau is not None and m is not None:
        raise InputError("give either tau or m, not both")
    limit = max_m(n, kind)
    if tau is not None:
        tau = np.atleast_1d(np.asarray(tau, dtype=float))
        if tau.size == 0 or not np.all(np.isfinite(tau)) or np.any(tau <= 0):
            raise InputError("tau must be a non-empty list of finite averaging times > 0 s")
        m = np.round(tau / dt)
        if np.any(m < 1):
            raise InputError(f"tau {tau[m < 1].min():g} s is shorter than the sampling period {dt:g} s")
    elif m is None:
        return choose_m(n, kind, per_decade)
    m = np.atleast_1d(np.asarray(m))
    if m.size == 0 or np.any(m < 1) or np.any(m != np.round(m)):
        raise InputError("m must be a non-empty list of integers >= 1")
    m = np.unique(m.astype(np.int64))
    if m[-1] > limit:
        raise InputError(
            f"tau = {m[-1] * dt:g} s (m = {m[-1]}) is beyond the longest averaging time the {kind} variance "
            f"allows for {n} samples at dt = {dt:g} s: tau <= {limit * dt:g} s (m <= {limit}); "
            "record longer or ask for shorter tau"
        )
    return m


def _as_columns(y: np.ndarray, dt: float, kind: Kind) -> np.ndarray:
    _check_kind(kind)
    if not (isinstance(dt, int | float | np.floating) and math.isfinite(dt) and dt > 0):
        raise InputError(f"sampling period dt must be a finite number > 0 s, got {dt!r}")
    y = np.asarray(y, dtype=float)
    if y.ndim == 1:
        y = y[:, None]
    if y.ndim != 2 or y.shape[1] == 0:
        raise InputError(f"samples must have shape (N,) or (N, k), got {y.shape}")
    n = y.shape[0]
    if n < _min_samples(kind):
        raise InputError(f"{n} samples are too few for the {kind} variance: need at least {_min_samples(kind)}")
    bad = ~np.isfinite(y)
    if bad.any():
        rows, cols = np.nonzero(bad)
        raise InputError(
            f"samples contain {bad.sum()} NaN/inf value(s) (first at sample {rows[0]}, column {cols[0]}): "
            "remove or repair them before computing Allan variances"
        )
    return y


# --------------------------------------------------------------------------------------------- estimators
def _phase(y: np.ndarray, dt: float) -> np.ndarray:
    """Phase x (N+1,) of one rate column: x_0 = 0, x_i = dt·Σ_{j<i}(y_j − ȳ) (mean removed for precision)."""
    x = np.empty(y.shape[0] + 1)
    x[0] = 0.0
    rates = x[1:]
    rates[:] = y
    rates -= rates.mean()
    np.cumsum(rates, out=rates)
    rates *= dt
    return x


def _sum_sq(v: np.ndarray) -> float:
    # einsum is several times faster than BLAS dot here (no thread start-up, one pass).
    return float(np.einsum("i,i->", v, v))


def _lagged_difference(x: np.ndarray, m: int, order: int, buffers: list[np.ndarray]) -> np.ndarray:
    """The order-th difference of x at lag m (Δ_m^order x), computed in the preallocated buffers."""
    a = x
    for k in range(order):
        out = buffers[k][: a.size - m]
        np.subtract(a[m:], a[:-m], out=out)
        a = out
    return a


def _difference_sums(x: np.ndarray, m_list: np.ndarray, order: int) -> np.ndarray:
    """Σ (Δ_m^order x)² per m, for one phase row x (order 2: Allan, order 3: Hadamard)."""
    buffers = [np.empty(x.size) for _ in range(order)]
    return np.array([_sum_sq(_lagged_difference(x, int(m), order, buffers)) for m in m_list])


def _allan_sums(x: np.ndarray, m_list: np.ndarray) -> np.ndarray:
    """Σ (x_{i+2m} − 2x_{i+m} + x_i)² per m, for one phase row x."""
    return _difference_sums(x, m_list, 2)


def _hadamard_sums(x: np.ndarray, m_list: np.ndarray) -> np.ndarray:
    """Σ (x_{i+3m} − 3x_{i+2m} + 3x_{i+m} − x_i)² per m, for one phase row x."""
    return _difference_sums(x, m_list, 3)


def _modified_sums(x: np.ndarray, m_list: np.ndarray) -> np.ndarray:
    """Σ_j (Σ_{i=j}^{j+m−1} x_{i+2m} − 2x_{i+m} + x_i)² per m (moving sum through a cumulative sum)."""
    buffers = [np.empty(x.size) for _ in range(2)]
    cs = np.empty(x.size + 1)
    out = np.empty(m_list.size)
    for i, m in enumerate(m_list):
        b = _lagged_difference(x, int(m), 2, buffers)
        c = cs[: b.size + 1]
        c[0] = 0.0
        np.cumsum(b, out=c[1:])
        out[i] = _sum_sq(c[m:] - c[:-m])
    return out


def _total_sums(x: np.ndarray, m_list: np.ndarray) -> np.ndarray:
    """Σ_{i=1}^{N−1} (x*_{i−m} − 2x_i + x*_{i+m})² per m, x* the phase reflected at both ends."""
    n1 = x.size  # N + 1 phase points, indices 0..N
    pad = int(m_list[-1])
    left = 2.0 * x[0] - x[pad:0:-1]  # x*_{-pad} .. x*_{-1}
    right = 2.0 * x[-1] - x[-2 : -2 - pad : -1]  # x*_{N+1} .. x*_{N+pad}
    xe = np.concatenate([left, x, right])
    centre = xe[pad + 1 : pad + n1 - 1]
    out = np.empty(m_list.size)
    e = np.empty(n1 - 2)
    for i, m in enumerate(m_list):
        np.add(xe[pad + 1 - m : pad + n1 - 1 - m], xe[pad + 1 + m : pad + n1 - 1 + m], out=e)
        e -= 2.0 * centre
        out[i] = _sum_sq(e)
    return out


_SUMS = {"allan": _allan_sums, "hadamard": _hadamard_sums, "modified": _modified_sums, "total": _total_sums}


def _normalise(kind: Kind, sums: np.ndarray, m: np.ndarray, n: int, dt: float) -> np.ndarray:
    tau2 = (m * dt) ** 2
    if kind == "allan":
        return sums / (2.0 * tau2 * (n - 2 * m + 1))
    if kind == "hadamard":
        return sums / (6.0 * tau2 * (n - 3 * m + 1))
    if kind == "modified":
        return sums / (2.0 * m.astype(float) ** 2 * tau2 * (n - 3 * m + 2))
    return sums / (2.0 * tau2 * (n - 1))


# ---------------------------------------------------------------------------------------------------- EDF
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
    """Greenhall eq. (8): phase averaged over 1/F of the sample spacing (F = ∞: no averaging)."""
    if math.isinf(F):
        return _sw(t, alpha + 2)
    return F * F * (2.0 * _sw(t, alpha) - _sw(t - 1.0 / F, alpha) - _sw(t + 1.0 / F, alpha))


def _sz(t: np.ndarray, F: float, alpha: int, d: int) -> np.ndarray:
    """Greenhall eq. (9): autocovariance of the d-th difference, binomial weights (−1)^k C(2d, d+k)."""
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
    """Equivalent degrees of freedom of a d-th difference variance (Greenhall & Riley 2003, cases 1–4).

    Parameters
    ----------
    alpha : int
        Noise exponent of S_y(f) ∝ f^α, −4..2, with α + 2d > 1.
    d : int
        1, 2 (Allan, modified Allan) or 3 (Hadamard).
    m : int
        Averaging factor.
    n_phase : int
        Number of phase points (N rate samples give N + 1).
    overlapping : bool
        Stride 1 (S = m) if True, else stride m (S = 1).
    modified : bool
        Phase averaged over m samples (F = 1), as in the modified Allan variance.
    """
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
    """EDF of the total variance at τ = m·dt from n rate samples: b·n/m − c (NIST SP1065 table 11).

    For α = 1, 2 (not in the table) the overlapping-AV EDF of Greenhall's algorithm is returned.
    """
    if alpha in _TOTVAR_BC:
        b, c = _TOTVAR_BC[alpha]
        return b * n / m - c
    return edf_greenhall(alpha, 2, m, n + 1, overlapping=True)


def _edf(kind: Kind, alpha: int, m: int, n: int) -> float:
    if kind == "total":
        return edf_total(alpha, m, n)
    d = 3 if kind == "hadamard" else 2
    return edf_greenhall(alpha, d, m, n + 1, overlapping=True, modified=kind == "modified")


def _alpha_range(kind: Kind) -> tuple[int, int]:
    return (-4, 2) if kind == "hadamard" else (-2, 2)


#: Half-width (in τ points) of the local log-log slope regression.
SLOPE_HALF_WINDOW = 2


def local_slopes(tau: np.ndarray, variance: np.ndarray, half_window: int = SLOPE_HALF_WINDOW) -> np.ndarray:
    """Least-squares slope of log σ² vs log τ over ±``half_window`` neighbouring τ, per column.

    Parameters
    ----------
    tau : ndarray, shape (T,)
    variance : ndarray, shape (T,) or (T, k)
        Non-positive values are ignored.

    Returns
    -------
    ndarray, same shape as ``variance``; NaN where fewer than two usable points are in the window.
    """
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


def identify_alpha(tau: np.ndarray, variance: np.ndarray, kind: Kind) -> np.ndarray:
    """Noise exponent α per τ and axis from the local log-log slope μ of the variance: α = −μ − 1, rounded.

    μ is the regression slope over ±2 neighbouring τ (:func:`local_slopes`). For AV, HV and TV a slope of −2
    (quantisation / white phase noise) maps to α = 2 (flicker phase noise, α = 1, has the same AV slope and
    is rare in IMUs). α is then made non-increasing in τ (a running minimum): inertial sensor noise goes from
    quantisation through white noise to flicker and random walk as τ grows, and this keeps one low point in a
    noisy long-τ tail from being read as white phase noise, whose EDF would be huge and its interval far too
    narrow. A single τ gives α = 0 (white noise).
    """
    variance = np.asarray(variance, dtype=float)
    lo, hi = _alpha_range(kind)
    if tau.size < 2:
        return np.zeros(variance.shape, dtype=int)
    mu = local_slopes(tau, variance)
    mu = np.where(np.isfinite(mu), mu, -1.0)
    alpha = np.rint(-mu - 1.0)
    if kind != "modified":
        alpha = np.where(mu <= -1.5, 2.0, alpha)
    alpha = np.minimum.accumulate(np.clip(alpha, lo, hi), axis=0)
    return alpha.astype(int)


def chi2_interval(variance: np.ndarray, edf: np.ndarray, confidence: float) -> tuple[np.ndarray, np.ndarray]:
    """Two-sided χ² interval [edf·σ̂²/χ²_{(1+c)/2}(edf), edf·σ̂²/χ²_{(1−c)/2}(edf)] (NIST SP1065 eq. 45)."""
    if not 0.0 < confidence < 1.0:
        raise InputError(f"confidence must lie in (0, 1), got {confidence!r}")
    hi_q = stats.chi2.ppf(0.5 + confidence / 2.0, edf)
    lo_q = stats.chi2.ppf(0.5 - confidence / 2.0, edf)
    return variance * edf / hi_q, variance * edf / lo_q


# ------------------------------------------------------------------------------------------------- public
def allan_family(
    y: np.ndarray,
    dt: float,
    kind: Kind = "allan",
    *,
    tau: np.ndarray | None = None,
    m: np.ndarray | None = None,
    per_decade: int = DEFAULT_PER_DECADE,
    confidence: float = DEFAULT_CONFIDENCE,
    alpha: int | np.ndarray | None = None,
) -> AllanResult:
    """Allan-family variance ``kind`` of rate samples with χ² confidence intervals.

    Parameters
    ----------
    y : ndarray, shape (N,) or (N, k)
        Rate samples (rad/s, m/s², …) at a constant period ``dt``; each column is one axis.
    dt : float
        Sampling period [s].
    kind : {"allan", "hadamard", "total", "modified"}
        The estimator (see the module docstring for the formulas).
    tau, m : array_like, optional
        Averaging times [s] (rounded to m = τ/dt) or averaging factors; at most one of them. Default:
        :func:`choose_m` (``per_decade`` log-spaced m up to :func:`max_m`).
    confidence : float
        Two-sided level of the χ² interval.
    alpha : int or array (T, k), optional
        Noise exponent assumed for the EDF; default: identified per τ from the local slope
        (:func:`identify_alpha`).

    Raises
    ------
    InputError
        Too few samples, NaN/inf samples, bad dt, τ outside [dt, longest τ the estimator allows].
    """
    y = _as_columns(y, dt, kind)
    n = y.shape[0]
    m_arr = _resolve_m(n, dt, kind, tau=tau, m=m, per_decade=per_decade)
    # One axis at a time: memory stays at a few rows of N values whatever the number of axes.
    sums = np.stack([_SUMS[kind](_phase(y[:, j], dt), m_arr) for j in range(y.shape[1])], axis=1)
    variance = _normalise(kind, sums, m_arr[:, None], n, dt)
    tau_arr = m_arr * dt
    if alpha is None:
        alpha_arr = identify_alpha(tau_arr, variance, kind)
    else:
        lo, hi = _alpha_range(kind)
        alpha_arr = np.broadcast_to(np.asarray(alpha), variance.shape).astype(int)
        if np.any(alpha_arr < lo) or np.any(alpha_arr > hi):
            raise InputError(f"alpha must lie in {lo}..{hi} for the {kind} variance")
    cache: dict[tuple[int, int], float] = {}
    edf = np.empty(variance.shape)
    for (i, j), a in np.ndenumerate(alpha_arr):
        key = (int(a), int(m_arr[i]))
        if key not in cache:
            cache[key] = _edf(kind, key[0], key[1], n)
        edf[i, j] = cache[key]
    ci_low, ci_high = chi2_interval(variance, edf, confidence)
    return AllanResult(
        kind=kind, dt=float(dt), n=n, m=m_arr, tau=tau_arr, variance=variance, ci_low=ci_low, ci_high=ci_high,
        edf=edf, alpha=alpha_arr, confidence=float(confidence),
    )


def stack_axes(results: list[AllanResult]) -> AllanResult:
    """Join results of the same kind, τ grid and samples computed on different axes into one (T, Σk) result.

    Raises
    ------
    ValueError
        If the results differ in kind, dt, n, m or confidence.
    """
    first = results[0]
    for r in results[1:]:
        if (r.kind, r.dt, r.n, r.confidence) != (first.kind, first.dt, first.n, first.confidence) or not np.array_equal(
            r.m, first.m
        ):
            raise ValueError("stack_axes: results differ in kind, dt, n, tau grid or confidence")
    cat = {f: np.hstack([getattr(r, f) for r in results]) for f in ("variance", "ci_low", "ci_high", "edf", "alpha")}
    return AllanResult(kind=first.kind, dt=first.dt, n=first.n, m=first.m, tau=first.tau, confidence=first.confidence,
                       **cat)


def allan_variance(y: np.ndarray, dt: float, **kwargs) -> AllanResult:
    """Maximal-overlap Allan variance, paper 000 eq. (2); see :func:`allan_family` for the arguments."""
    return allan_family(y, dt, "allan", **kwargs)


def hadamard_variance(y: np.ndarray, dt: float, **kwargs) -> AllanResult:
    """Overlapping Hadamard variance (paper 000 section 2); see :func:`allan_family`."""
    return allan_family(y, dt, "hadamard", **kwargs)


def total_variance(y: np.ndarray, dt: float, **kwargs) -> AllanResult:
    """Total variance (paper 000 section 2, NIST SP1065 eq. 25); see :func:`allan_family`."""
    return allan_family(y, dt, "total", **kwargs)


def modified_allan_variance(y: np.ndarray, dt: float, **kwargs) -> AllanResult:
    """Modified Allan variance (NIST SP1065 eq. 14); see :func:`allan_family`."""
    return allan_family(y, dt, "modified", **kwargs)
