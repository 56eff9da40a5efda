"""Sequential test of an axis's white-noise level against its reference: Page's CUSUM (Page 1954; Basseville & Nikiforov
1993, eq. 2.2.9) on disjoint pair differences d_k = y_{2k+1} − y_{2k} (variance v = 2·AV(dt) ∈ [v_lo, v_hi]), per
direction (up: v₀ = v_hi, v₁ = ρ² v_ref; down: v₀ = v_lo, v₁ = v_ref/ρ²)

    s_k = ½ ln(v₀/v₁) + ½ d_k² (1/v₀ − 1/v₁),    S_k = max(0, S_{k−1} + s_k),

alarm at S_k > h = ln(3600·r/λ): Lorden's ARL₀ ≥ e^h (eq. 5.2.73), ≤ λ false alarms per hour at r pairs per second.
Upward d_k² is capped at :data:`SPIKE_Z`² v₀. Why: docs/analysis.md."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

#: Noise-density ratio the test is tuned to detect (live / reference, either way).
DEFAULT_RATIO = 1.5
#: False alarms per hour of data by default: here per test of one axis; the pipelines give it for a whole unit and
#: share it (:func:`per_test`).
DEFAULT_FALSE_ALARMS_PER_HOUR = 0.1
#: The upward CUSUM counts a pair's d² at most this many sd of the reference, squared (6e-5 of increments beyond).
SPIKE_Z = 4.0


@dataclass(frozen=True)
class LevelAlarm:
    """A CUSUM alarm: ``direction`` "up" or "down", ``time_s`` fired, ``since_s`` the CUSUM's last zero before [s]."""

    direction: str
    time_s: float
    since_s: float


@dataclass(frozen=True)
class NoiseLevel:
    """The test's outcome on one axis: live / reference density ``ratio`` (since the alarm's change) and its 95 %
    ``ratio_ci``, the first ``alarm`` (or None), ``threshold`` h, ``increments`` tested, ``reference_ci`` (the
    reference's interval as density ratios) and ``least_change`` (the ratio ≥ 1 a confirmed change reaches)."""

    ratio: float
    ratio_ci: tuple[float, float]
    alarm: LevelAlarm | None
    threshold: float
    increments: int
    reference_ci: tuple[float, float] = (1.0, 1.0)
    least_change: float = 1.0

    @property
    def sustained(self) -> bool:
        """An alarm the level since its change confirms (beyond the reference's interval and ``least_change``)."""
        if self.alarm is None:
            return False
        if self.alarm.direction == "up":
            return self.ratio_ci[0] > self.reference_ci[1] and self.ratio >= self.least_change
        return self.ratio_ci[1] < self.reference_ci[0] and self.ratio <= 1.0 / self.least_change


def threshold(false_alarms_per_hour: float, increments_per_s: float) -> float:
    """h = ln(3600·r/λ): Lorden's ARL₀ ≥ e^h at r increments per second gives at most λ false alarms per hour."""
    if not false_alarms_per_hour > 0:
        raise ValueError(f"false alarms per hour must be > 0, got {false_alarms_per_hour!r}")
    return math.log(max(3600.0 * increments_per_s / false_alarms_per_hour, math.e))


def directions(v_ref: float, v_interval: tuple[float, float],
               ratio: float) -> list[tuple[str, float, float, float]]:
    """(direction, a, b, cap) per CUSUM, increment a + b·min(d², cap); a change inside the reference's interval is
    left out."""
    v_lo, v_hi = v_interval
    out = []
    for direction, v0, v1 in (("up", v_hi, ratio**2 * v_ref), ("down", v_lo, v_ref / ratio**2)):
        if (direction == "up" and v1 > v0) or (direction == "down" and v1 < v0):
            cap = SPIKE_Z**2 * v0 if direction == "up" else math.inf
            out.append((direction, 0.5 * math.log(v0 / v1), 0.5 * (1.0 / v0 - 1.0 / v1), cap))
    return out


def pair_differences(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(d_k, index of the pair's second sample) over disjoint pairs with both samples finite."""
    y = np.asarray(y, dtype=float)
    m = y.size // 2
    d = y[1: 2 * m: 2] - y[0: 2 * m: 2]
    ok = np.isfinite(d)
    return d[ok], (2 * np.arange(m) + 1)[ok]


def _cusum_alarm(llr: np.ndarray, h: float) -> tuple[int, int] | None:
    """(alarm index, change index) of Page's CUSUM on ``llr``, S_k = X_k − min(0, min_{j≤k} X_j); None without alarm."""
    x = np.cumsum(llr)
    s = x - np.minimum(np.minimum.accumulate(x), 0.0)
    over = np.flatnonzero(s > h)
    if not over.size:
        return None
    k = int(over[0])
    zeros = np.flatnonzero(s[:k] <= 0.0)
    return k, (int(zeros[-1]) + 1 if zeros.size else 0)


def ratio_interval(mean_d2: float, n: int, v_ref: float) -> tuple[float, tuple[float, float]]:
    """√(mean_d2 / v_ref) from the mean d² [u²] of ``n`` pair differences, and its 95 % χ² interval."""
    lo, hi = stats.chi2.ppf([0.975, 0.025], n)
    return math.sqrt(mean_d2 / v_ref), (math.sqrt(mean_d2 * n / lo / v_ref), math.sqrt(mean_d2 * n / hi / v_ref))


def _ratio(d: np.ndarray, v_ref: float) -> tuple[float, tuple[float, float]]:
    return ratio_interval(float(np.mean(d * d)), d.size, v_ref)


def watch_noise_level(y: np.ndarray, dt: float, v_ref: float, v_interval: tuple[float, float], *,
                      ratio: float = DEFAULT_RATIO,
                      false_alarms_per_hour: float = DEFAULT_FALSE_ALARMS_PER_HOUR,
                      directions_of: tuple[str, ...] = ("up", "down"),
                      least_change: float | None = None, min_pairs: int = 100) -> NoiseLevel:
    """Both CUSUMs (those of ``directions_of``) on ``y`` [u] at ``dt`` [s] against the reference's E[(y_{t+1} −
    y_t)²] ``v_ref`` [u²] within ``v_interval``, tuned to a density ``ratio`` ρ > 1, λ = ``false_alarms_per_hour``
    per direction, confirmed at ``least_change`` (None: √ρ) on ≥ ``min_pairs`` pairs. ValueError on too few pairs, a
    bad reference or ρ ≤ 1."""
    if not ratio > 1.0:
        raise ValueError(f"the ratio to detect must be > 1, got {ratio!r}")
    v_lo, v_hi = v_interval
    if not (0 < v_lo <= v_ref <= v_hi):
        raise ValueError(f"reference variance {v_ref!r} must be positive and inside its interval {v_interval!r}")
    d, index = pair_differences(y)
    if d.size < min_pairs:
        raise ValueError(f"{d.size} pair differences are too few for the noise-level test ({min_pairs} or more)")
    h = threshold(false_alarms_per_hour, 0.5 / dt)
    d2 = d * d
    alarms = []
    for direction, a, b, cap in directions(v_ref, v_interval, ratio):
        if direction not in directions_of:
            continue
        found = _cusum_alarm(a + b * np.minimum(d2, cap), h)
        if found is not None:
            alarms.append(LevelAlarm(direction, float(index[found[0]] * dt), float(index[found[1]] * dt)))
    alarm = min(alarms, key=lambda a: a.time_s) if alarms else None
    since = d if alarm is None else d[index * dt >= alarm.since_s]
    value, ci = _ratio(since if since.size >= min_pairs else d, v_ref)
    return NoiseLevel(value, ci, alarm, h, int(d.size), (math.sqrt(v_lo / v_ref), math.sqrt(v_hi / v_ref)),
                      math.sqrt(ratio) if least_change is None else least_change)


#: The tests each axis runs: noise up and down, bias step, new line, the specification's limit, and the Allan
#: variance up and down at each of ``allan_watch.DEFAULT_TAUS`` (two).
TESTS_PER_AXIS = 9


def per_test(false_alarms_per_hour: float, axes: int) -> float:
    """λ [1/h] per test of one axis: ``false_alarms_per_hour`` shared among ``axes`` × :data:`TESTS_PER_AXIS` tests."""
    return false_alarms_per_hour / (axes * TESTS_PER_AXIS)


#: Density ratio (live / limit) the test against a specification's limit is tuned to.
LIMIT_RATIO = 1.1


def beyond_limit(y: np.ndarray, dt: float, v_limit: float, *, ratio: float = LIMIT_RATIO,
                 false_alarms_per_hour: float = DEFAULT_FALSE_ALARMS_PER_HOUR) -> NoiseLevel:
    """The upward CUSUM alone on ``y`` [u] at ``dt`` [s] against v₀ = ``v_limit`` [u²] (a spec's density), v₁ =
    ``ratio``² v₀; ratio live / limit. ValueError as :func:`watch_noise_level`."""
    return watch_noise_level(y, dt, v_limit, (v_limit, v_limit), ratio=ratio,
                             false_alarms_per_hour=false_alarms_per_hour, directions_of=("up",), least_change=1.0)

