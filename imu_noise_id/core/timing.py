"""The sampling period of a series of stamps, one rule for every reader and command (docs/bags.md, "The sample
period"): a declared rate wins; regular stamps give the median neighbour interval, bursty ones (over
:data:`BURST_FRACTION` under half the period) the index regression, refused if the receive times disagree beyond
:data:`AGREE`; halves differing beyond :data:`HALVES_AGREE` warned."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import InputError

#: Fraction of neighbouring-message intervals shorter than half the period above which stamps are bursty.
BURST_FRACTION = 0.05
#: Relative difference within which two period estimates agree.
AGREE = 0.01
#: Relative difference of the two halves' regression periods above which the rate is said to change.
HALVES_AGREE = 0.02
#: Intervals within this many steps of a whole number of steps are on the lattice of sample-time stamps.
LATTICE_TOLERANCE = 0.1
#: Fraction of intervals on the lattice for stamps to be sample times (with lost messages between some).
LATTICE_FRACTION = 0.95
#: Stamps on a lattice that would mean more than this fraction of lost messages are bursts (regular delivery).
MAX_LOST = 0.5
#: The regression's lag is this fraction of the record (in messages).
LAG_FRACTION = 0.1
#: Pairs of stamps each estimate looks at, at most (evenly spread over longer records).
MAX_PAIRS = 200_000
#: The fix named whenever the stamps cannot be trusted.
RATE_HINT = "pass --rate HZ with the sensor's configured output rate"


@dataclass(frozen=True)
class SamplePeriod:
    """The period ``value`` [s] chosen (the best estimate even with a ``refusal``), its ``source``
    (``median_interval``, ``index_regression``, ``declared``), all ``estimates`` (name → [s]), ``bursty`` (stamps are
    not sample times), ``warnings``, ``notes`` and ``refusal`` (why no period can be trusted, or None)."""

    value: float
    source: str
    estimates: dict[str, float] = field(default_factory=dict)
    bursty: bool = False
    warnings: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    refusal: str | None = None

    @property
    def rate_hz(self) -> float:
        """1 / period [Hz]."""
        return 1.0 / self.value

    @property
    def trusted(self) -> bool:
        """No warning and no refusal (or declared)."""
        return self.refusal is None and not self.warnings

    def require(self) -> float:
        """The period [s]; raises :class:`InputError` naming the fix when it cannot be trusted."""
        if self.refusal is not None:
            raise InputError(self.refusal)
        return self.value

    def describe(self) -> str:
        """One line: the rate, its source and the other estimates."""
        names = {"median_interval": "median stamp interval", "index_regression": "regression of stamp on message "
                 "index", "span_count": "span/count", "receive_regression": "bag receive times",
                 "declared": "declared (--rate)"}
        others = ", ".join(f"{names[k]} {1 / v:.6g} Hz" for k, v in self.estimates.items()
                           if k != self.source and np.isfinite(v) and v > 0)
        return f"{self.rate_hz:.6g} Hz from the {names[self.source]}" + (f" (other estimates: {others})"
                                                                          if others else "")


def _check(t: np.ndarray) -> np.ndarray:
    t = np.asarray(t, dtype=float)
    if t.shape[0] < 2 or not np.isfinite(t).all():
        raise InputError("time stamps must be finite and increasing (need at least 2 samples)")
    i = _starts(t.shape[0], 1)
    if np.median(t[i + 1] - t[i]) <= 0:
        raise InputError("time stamps must be finite and increasing (need at least 2 samples)")
    return t


def _starts(n: int, span: int) -> np.ndarray:
    count = n - span
    return np.arange(0, count, max(1, count // MAX_PAIRS))


def _lag_slope(t: np.ndarray, index: np.ndarray) -> float:
    """Median of the lag-k slopes of ``t`` on ``index``, k = :data:`LAG_FRACTION` of the record."""
    n = t.shape[0]
    k = max(1, int(n * LAG_FRACTION))
    i = _starts(n, k)
    steps = (index[i + k] - index[i]).astype(float)
    ok = steps > 0
    if not ok.any():
        return float("nan")
    return float(np.median((t[i + k] - t[i])[ok] / steps[ok]))


def _neighbour_intervals(t: np.ndarray, index: np.ndarray) -> np.ndarray:
    i = _starts(t.shape[0], 1)
    d = t[i + 1] - t[i]
    steps = index[i + 1] - index[i]
    neighbours = steps == 1
    return d[neighbours] if neighbours.any() else d / np.maximum(steps, 1)


def _median_interval(intervals: np.ndarray, resolution: float) -> float:
    """The median of ``intervals`` [s], read below the stamps' float ``resolution`` [s]: stamps since 1970 in float64
    seconds are rounded to 2.4·10⁻⁷ s, so their intervals take whole multiples of it and the median lands on one (a
    200 Hz record read 199.995 Hz); the mean of the intervals within two such steps of the median (the rounded values on
    both sides of the true one, whose roundings cancel on average) is not bound to the step."""
    median = float(np.median(intervals))
    near = intervals[np.abs(intervals - median) <= 2.0 * resolution]
    return float(np.mean(near)) if near.size else median


def _lattice(intervals: np.ndarray, resolution: float) -> tuple[float, bool]:
    """(period, whether the intervals are whole multiples of a step within :data:`LATTICE_TOLERANCE`); ``resolution``
    [s] the stamps' float step (:func:`_median_interval`)."""
    step = float(np.quantile(intervals, 0.1))
    if not step > 0:
        return _median_interval(intervals, resolution), False
    ratio = intervals / step
    whole = np.rint(ratio)
    near = (np.abs(ratio - whole) < LATTICE_TOLERANCE) & (whole >= 1)
    on_lattice = bool(np.mean(near) >= LATTICE_FRACTION)
    ones = intervals[near & (whole == 1)]
    return _median_interval(ones if on_lattice and ones.size else intervals, resolution), on_lattice


def _halves(t: np.ndarray, index: np.ndarray) -> tuple[float, float] | None:
    n = t.shape[0]
    if n < 200:
        return None
    h = n // 2
    return _lag_slope(t[:h], index[:h]), _lag_slope(t[h:], index[h:])


def _relative(a: float, b: float) -> float:
    return abs(a - b) / b if np.isfinite(a) and np.isfinite(b) and b > 0 else float("inf")


def check_declared_rate(declared_hz: float) -> None:
    """Refuse a declared rate (``--rate`` [Hz]) that is not a positive finite number."""
    if not (np.isfinite(declared_hz) and declared_hz > 0):
        raise InputError(f"--rate must be a positive number of Hz, got {declared_hz}")


def estimate_period(
    t: np.ndarray,
    *,
    index: np.ndarray | None = None,
    receive: np.ndarray | None = None,
    declared_hz: float | None = None,
) -> SamplePeriod:
    """The period of sorted stamps ``t`` [s] (module docstring), with each sample's message ``index`` (N,), bag
    ``receive`` times [s] and ``declared_hz``; InputError on fewer than two or non-increasing stamps or a bad
    declared rate."""
    t = _check(t)
    index = np.arange(t.shape[0]) if index is None else np.asarray(index)
    intervals = _neighbour_intervals(t, index)
    regression = _lag_slope(t, index)
    span = (t[-1] - t[0]) / (index[-1] - index[0]) if index[-1] > index[0] else float("nan")
    single, on_lattice = _lattice(intervals, float(np.spacing(max(abs(t[0]), abs(t[-1])))))
    estimates = {"median_interval": single, "index_regression": regression, "span_count": float(span)}
    reference = regression if np.isfinite(regression) and regression > 0 else single
    bunched = float(np.mean(intervals < 0.5 * reference))
    lost = 1.0 - single / reference
    warnings: list[str] = []
    notes: list[str] = []
    refusal = None
    value, source, bursty = single, "median_interval", False
    if (on_lattice and lost > MAX_LOST) or (not on_lattice and bunched > BURST_FRACTION):
        value, source, bursty = regression, "index_regression", True
        typical = np.median(intervals)
        alternative = (f" (or {1 / single:.6g} Hz with {100 * lost:.0f} % of the messages lost in transport: then "
                       f"pass --rate {1 / single:.6g})" if on_lattice else "")
        warnings.append(
            f"stamps are bursty: {100 * bunched:.0f} % of the intervals between neighbouring messages are shorter "
            f"than half the period (median interval {typical * 1e3:.4g} ms = {1 / typical:.6g} Hz): they are "
            f"delivery times, not sample times. The period comes from the regression of stamp on message index "
            f"({1 / regression:.6g} Hz){alternative} and the samples are taken as equally spaced; if the sensor's "
            f"rate is known, {RATE_HINT}"
        )
    elif not on_lattice and _relative(single, regression) > AGREE and lost < 0:
        warnings.append(
            f"stamps jitter and disagree: median interval {1 / single:.6g} Hz (used), regression of stamp on message "
            f"index {1 / regression:.6g} Hz; if the sensor's rate is known, {RATE_HINT}"
        )
    if receive is not None:
        received = _lag_slope(np.asarray(receive, dtype=float), index)
        estimates["receive_regression"] = received
        off = _relative(received, value)
        if bursty and off > AGREE:
            refusal = (
                f"the stamps cannot give the sample period: header stamps are bursty (median interval "
                f"{1 / np.median(intervals):.6g} Hz, regression on message index {1 / regression:.6g} Hz) and the "
                f"bag's receive times say {1 / received:.6g} Hz ({100 * off:.1f} % apart): {RATE_HINT}"
            )
        elif off > 0.05 and not bursty:
            notes.append(f"the bag's receive times run at {1 / received:.6g} Hz, the header stamps (used) at "
                         f"{1 / value:.6g} Hz (re-recorded or replayed at another speed?)")
    halves = _halves(t, index)
    if halves is not None and _relative(halves[1], halves[0]) > HALVES_AGREE:
        warnings.append(
            f"the rate changes within the record: {1 / halves[0]:.6g} Hz in the first half, {1 / halves[1]:.6g} Hz "
            "in the second; the analyses assume one constant rate (split the record, or check the driver)"
        )
    if declared_hz is None:
        return SamplePeriod(value, source, estimates, bursty, tuple(warnings), tuple(notes), refusal)
    check_declared_rate(declared_hz)
    estimates["declared"] = 1.0 / declared_hz
    off = _relative(1.0 / declared_hz, value)
    kept = [w for w in warnings if w.startswith("the rate changes")]
    if refusal is not None or bursty:
        notes.append(f"the stamps cannot give the period by themselves; the declared --rate {declared_hz:g} Hz is "
                     "used")
    elif off > AGREE:
        kept.insert(0, f"--rate {declared_hz:g} Hz is used although the stamps say {1 / value:.6g} Hz "
                       f"({100 * off:.1f} % apart)")
    return SamplePeriod(1.0 / declared_hz, "declared", estimates, bursty, tuple(kept), tuple(notes))


def sampling_period(t: np.ndarray) -> float:
    """The period [s] of stamps ``t`` alone (:func:`estimate_period`); InputError as there."""
    return estimate_period(t).value
