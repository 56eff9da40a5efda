"""Allan-family variances of rate samples y [u] over τ = m·dt, by axis; phase x_0 = 0, x_i = dt·Σ_{j<i} (y_j − ȳ):

* ``allan``    AV(m)  = Σ_i (x_{i+2m} − 2x_{i+m} + x_i)² / (2 τ² (N − 2m + 1))         (paper 000 eq. 2)
* ``hadamard`` HV(m)  = Σ_i (x_{i+3m} − 3x_{i+2m} + 3x_{i+m} − x_i)² / (6 τ² (N − 3m + 1)) (paper 000 sec. 2)
* ``total``    TV(m)  = Σ_{i=1}^{N−1} (x*_{i−m} − 2x_i + x*_{i+m})² / (2 τ² (N − 1)), x* the phase reflected oddly at
  both ends (paper 000 sec. 2; NIST SP1065 eq. 25)
* ``modified`` MAV(m) = Σ_j (Σ_{i=j}^{j+m−1} x_{i+2m} − 2x_{i+m} + x_i)² / (2 m² τ² (N − 3m + 2)) (SP1065 eq. 14)

O(N) per τ; equal to allantools' ``oadev``, ``ohdev``, ``totdev``, ``mdev`` (``data_type="freq"``)."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from ..constants import CONFIDENCE_95
from ..errors import InputError
from .edf import alpha_range, chi2_interval, edf_of, identify_alpha

Kind = Literal["allan", "hadamard", "total", "modified"]
KINDS: tuple[str, ...] = ("allan", "hadamard", "total", "modified")

#: Default number of averaging times per decade of τ.
DEFAULT_PER_DECADE = 8
#: Default two-sided confidence level of the intervals.
DEFAULT_CONFIDENCE = CONFIDENCE_95


@dataclass(frozen=True)
class AllanResult:
    """One Allan-family variance of k axes over T averaging times.

    Attributes
    ----------
    kind : {"allan", "hadamard", "total", "modified"}; dt : sampling period [s]; n : samples per axis used
    m, tau : (T,) averaging factors and times τ = m·dt [s]; variance : (T, k) the estimate [u²]
    ci_low, ci_high, edf, alpha : (T, k) ``confidence`` χ² interval, its EDF and the exponent α (S_y ∝ f^α) assumed
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

    def column(self, j: int) -> AllanResult:
        """The result of axis ``j`` alone (arrays of shape (T, 1))."""
        pick = slice(j, j + 1)
        return replace(self, variance=self.variance[:, pick], ci_low=self.ci_low[:, pick],
                       ci_high=self.ci_high[:, pick], edf=self.edf[:, pick], alpha=self.alpha[:, pick])

    def from_index(self, i: int) -> AllanResult:
        """The result at the averaging times from index ``i`` on (every axis)."""
        cut = slice(i, None)
        return replace(self, m=self.m[cut], tau=self.tau[cut], variance=self.variance[cut], ci_low=self.ci_low[cut],
                       ci_high=self.ci_high[cut], edf=self.edf[cut], alpha=self.alpha[cut])


# --------------------------------------------------------------------------------------------------- τ grid
def max_m(n: int, kind: Kind) -> int:
    """Largest m the estimator defines for n samples (0 if none): AV (n − 1)/2, HV (n − 1)/3, MAV n/3, TV τ ≤ T/2."""
    _check_kind(kind)
    if kind == "hadamard":
        return max((n - 1) // 3, 0)
    if kind == "modified":
        return max(n // 3, 0)
    return max((n - 1) // 2, 0)


def choose_m(
    n: int, kind: Kind = "allan", per_decade: int = DEFAULT_PER_DECADE, m_max: int | None = None
) -> np.ndarray:
    """Log-spaced factors 1 ≤ m ≤ ``m_max`` (default and always: :func:`max_m`), ~``per_decade`` a decade; InputError
    if none."""
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
def phase(y: np.ndarray, dt: float) -> np.ndarray:
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
    buffers = [np.empty(x.size) for _ in range(order)]
    return np.array([_sum_sq(_lagged_difference(x, int(m), order, buffers)) for m in m_list])


def second_differences(y: np.ndarray, dt: float, m_list: np.ndarray) -> Iterator[tuple[int, np.ndarray]]:
    """(m, x_{i+2m} − 2x_{i+m} + x_i) per m, x the phase [u·s]: the AV's terms (paper 000 eq. 2), one reused buffer."""
    x = phase(np.asarray(y, dtype=float), dt)
    buffers = [np.empty(x.size) for _ in range(2)]
    for m in m_list:
        yield int(m), _lagged_difference(x, int(m), 2, buffers)


def _allan_sums(x: np.ndarray, m_list: np.ndarray) -> np.ndarray:
    return _difference_sums(x, m_list, 2)


def _hadamard_sums(x: np.ndarray, m_list: np.ndarray) -> np.ndarray:
    return _difference_sums(x, m_list, 3)


def _modified_sums(x: np.ndarray, m_list: np.ndarray) -> np.ndarray:
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
    """Allan-family variance ``kind`` (module docstring) of rate samples, with χ² confidence intervals.

    Parameters
    ----------
    y : (N,) or (N, k) rate samples [u] at constant period ``dt`` [s], one column per axis
    tau, m : averaging times [s] (rounded to m = τ/dt) or factors, at most one; default :func:`choose_m`
    confidence : the intervals' two-sided level; alpha : int or (T, k) EDF noise exponent (default: identified)

    Raises InputError on too few or non-finite samples, a bad dt, or τ outside [dt, longest τ].
    """
    y = _as_columns(y, dt, kind)
    n = y.shape[0]
    m_arr = _resolve_m(n, dt, kind, tau=tau, m=m, per_decade=per_decade)
    # One axis at a time: memory stays at a few rows of N values whatever the number of axes.
    sums = np.stack([_SUMS[kind](phase(y[:, j], dt), m_arr) for j in range(y.shape[1])], axis=1)
    variance = _normalise(kind, sums, m_arr[:, None], n, dt)
    tau_arr = m_arr * dt
    if alpha is None:
        alpha_arr = identify_alpha(tau_arr, variance, kind, y, m_arr)
    else:
        lo, hi = alpha_range(kind)
        alpha_arr = np.broadcast_to(np.asarray(alpha), variance.shape).astype(int)
        if np.any(alpha_arr < lo) or np.any(alpha_arr > hi):
            raise InputError(f"alpha must lie in {lo}..{hi} for the {kind} variance")
    cache: dict[tuple[int, int], float] = {}
    edf = np.empty(variance.shape)
    for (i, j), a in np.ndenumerate(alpha_arr):
        key = (int(a), int(m_arr[i]))
        if key not in cache:
            cache[key] = edf_of(kind, key[0], key[1], n)
        edf[i, j] = cache[key]
    ci_low, ci_high = chi2_interval(variance, edf, confidence)
    return AllanResult(
        kind=kind, dt=float(dt), n=n, m=m_arr, tau=tau_arr, variance=variance, ci_low=ci_low, ci_high=ci_high,
        edf=edf, alpha=alpha_arr, confidence=float(confidence),
    )


def stack_axes(results: list[AllanResult]) -> AllanResult:
    """Same-kind results of different axes as one (T, Σk) result; ValueError if kind, dt, n, m or confidence differ."""
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
