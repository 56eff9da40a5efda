"""Checks and documented repairs of sampled time series (pure numpy; docs/bags.md, "Repairs")."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .errors import InputError
from .timing import SamplePeriod, estimate_period

#: Stamps are clock (epoch) times if the smallest non-zero one exceeds this [s]; zero stamps among them are unset.
ZERO_STAMP_CLOCK_S = 60.0
#: A stamp this many periods away from both message neighbours (which agree with each other) is a clock glitch.
GLITCH_PERIODS = 100
#: A gap is an interval longer than this many periods.
GAP_FACTOR = 1.5
#: No IMU measures more than this: (gyro [rad/s] ≈ 57 000 °/s, accel [m/s²] ≈ 1000 g).
IMU_MAX_ABS: tuple[float, float] = (1e3, 1e4)
#: Above this fraction of impossible values the series is rejected rather than repaired.
MAX_IMPLAUSIBLE_FRACTION = 0.01
#: At most this many gaps are listed one by one in the notes.
MAX_LISTED_GAPS = 10


class QualityError(InputError):
    """The series cannot be repaired into something usable."""


@dataclass
class QualityReport:
    """What :func:`repair_time_series` found and did: ``n_input``, ``n_output`` samples; ``n_nonfinite``,
    ``n_implausible``, ``n_zero_stamps``, ``n_glitches``, ``n_duplicates`` dropped by each rule; ``n_backwards``
    (sorted if > 0); the ``period``; ``positions`` (n_output,) of the kept samples; ``gaps`` (start [s], length [s],
    missing samples); ``t0`` [s]."""

    n_input: int
    n_output: int = 0
    n_nonfinite: int = 0
    n_implausible: int = 0
    n_zero_stamps: int = 0
    n_glitches: int = 0
    n_backwards: int = 0
    n_duplicates: int = 0
    period: SamplePeriod | None = None
    positions: np.ndarray | None = None
    gaps: list[tuple[float, float, int]] = field(default_factory=list)
    t0: float = 0.0

    @property
    def repaired(self) -> bool:
        """True if any sample was dropped or moved."""
        return bool(
            self.n_nonfinite or self.n_implausible or self.n_zero_stamps or self.n_glitches or self.n_backwards
            or self.n_duplicates
        )

    @property
    def dt(self) -> float:
        """The period [s] (nan before it is estimated)."""
        return self.period.value if self.period is not None else float("nan")

    @property
    def _gap_reference(self) -> str:
        return "99th-percentile interval of the bursty stamps" if self.period and self.period.bursty else (
            f"period {self.dt:.4g} s")

    def notes(self, what: str = "samples") -> list[str]:
        """Human-readable notes, one per finding."""
        notes: list[str] = []
        if self.n_nonfinite:
            notes.append(f"dropped {self.n_nonfinite} of {self.n_input} {what} with NaN/inf time or values")
        if self.n_implausible:
            notes.append(
                f"dropped {self.n_implausible} {what} with physically impossible values (corrupt data or wrong units)"
            )
        if self.n_zero_stamps:
            notes.append(f"dropped {self.n_zero_stamps} {what} with a zero header stamp (stamp not set)")
        if self.n_glitches:
            notes.append(f"dropped {self.n_glitches} {what} whose stamp jumps away from both neighbours by more than "
                         f"{GLITCH_PERIODS} periods (a clock glitch, e.g. one stamp in the future)")
        if self.n_backwards:
            notes.append(f"stamps went backwards {self.n_backwards} time(s): {what} sorted by stamp")
        if self.n_duplicates:
            notes.append(f"dropped {self.n_duplicates} {what} with a duplicated stamp (kept the first)")
        if self.period is not None:
            notes += list(self.period.warnings) + list(self.period.notes)
        if self.gaps:
            total = sum(g[1] for g in self.gaps)
            missing = sum(g[2] for g in self.gaps)
            listed = ", ".join(
                f"at t={start - self.t0:.3f} s for {length:.3f} s" for start, length, _ in self.gaps[:MAX_LISTED_GAPS]
            )
            more = f" and {len(self.gaps) - MAX_LISTED_GAPS} more" if len(self.gaps) > MAX_LISTED_GAPS else ""
            notes.append(
                f"{len(self.gaps)} gap(s) longer than {GAP_FACTOR:g}× the {self._gap_reference} "
                f"(≈{missing} missing {what}, {total:.3f} s in total; times from the first stamp): {listed}{more}"
            )
        return notes


def _as_columns(data: np.ndarray | Sequence[np.ndarray]) -> tuple[list[np.ndarray], bool]:
    if isinstance(data, np.ndarray):
        return [data], True
    return list(data), False


def _take(columns: list[np.ndarray], keep: np.ndarray) -> list[np.ndarray]:
    return [c[keep] for c in columns]


def find_gaps(t: np.ndarray, period: SamplePeriod | float, gap_factor: float = GAP_FACTOR
              ) -> list[tuple[float, float, int]]:
    """Intervals of sorted stamps ``t`` longer than ``gap_factor`` × the period (bursty stamps: × their
    99th-percentile interval): (start [s], length [s], missing samples)."""
    dt = period.value if isinstance(period, SamplePeriod) else float(period)
    if t.shape[0] < 2 or not dt > 0:
        return []
    steps = np.diff(t)
    reference = max(dt, float(np.quantile(steps, 0.99))) if isinstance(period, SamplePeriod) and period.bursty \
        else dt
    where = np.flatnonzero(steps > gap_factor * reference)
    return [(float(t[i]), float(steps[i]), max(round(steps[i] / dt) - 1, 1)) for i in where]


def _glitches(t: np.ndarray) -> np.ndarray:
    """Samples more than :data:`GLITCH_PERIODS` periods from both neighbours, which agree."""
    bad = np.zeros(t.shape[0], dtype=bool)
    if t.shape[0] < 3:
        return bad
    steps = np.diff(t)
    sample = steps[:: max(1, steps.shape[0] // 200_000)]
    forward = sample[sample > 0]
    if forward.size == 0:
        return bad
    limit = GLITCH_PERIODS * float(np.median(forward))
    big = np.abs(steps) > limit
    i = np.flatnonzero(big[:-1] & big[1:])  # sample i + 1 jumps in and out
    bad[i[np.abs(t[i + 2] - t[i]) < 0.1 * limit] + 1] = True
    return bad


def repair_time_series(
    t: np.ndarray,
    data: np.ndarray | Sequence[np.ndarray],
    *,
    gap_factor: float = GAP_FACTOR,
    min_samples: int = 2,
    max_abs: Sequence[float | None] | None = None,
    receive: np.ndarray | None = None,
    declared_hz: float | None = None,
) -> tuple[np.ndarray, np.ndarray | list[np.ndarray], QualityReport]:
    """Drop bad samples, sort, drop duplicates, estimate the period and find gaps (module docstring).

    Parameters
    ----------
    t : (N,) stamps [s]; data : (N, ...) array or a sequence of them; receive : (N,) receive times [s] or None
    gap_factor, min_samples, declared_hz : gap threshold (× period), fewest kept samples, ``--rate``
    max_abs : per data array the largest plausible magnitude (None: no limit), e.g. :data:`IMU_MAX_ABS`

    Returns repaired (t, data, report), the inputs when nothing changed. Raises QualityError below ``min_samples`` or
    beyond :data:`MAX_IMPLAUSIBLE_FRACTION` implausible, InputError on a bad declared rate.
    """
    t = np.asarray(t, dtype=float)
    columns, single = _as_columns(data)
    n_data = len(columns)
    n = t.shape[0]
    # Positions and receive times travel with the samples through every drop and sort.
    columns.append(np.arange(n, dtype=np.int32 if n < 2**31 else np.int64))
    if receive is not None:
        columns.append(np.asarray(receive, dtype=float))
    if max_abs is not None:
        max_abs = [*max_abs, *[None] * (len(columns) - n_data)]
    if any(c.shape[0] != n for c in columns):
        raise ValueError("repair_time_series: t and data have different numbers of samples")
    report = QualityReport(n_input=n)

    finite = np.isfinite(t)
    for c in columns:
        finite &= np.isfinite(c.reshape(n, -1)).all(axis=1)
    report.n_nonfinite = int(n - np.count_nonzero(finite))
    if report.n_nonfinite:
        if not finite.any():
            raise QualityError(f"all {n} samples have NaN/inf time or values: nothing usable")
        t, columns = t[finite], _take(columns, finite)

    if max_abs is not None:
        m = t.shape[0]
        plausible = np.ones(m, dtype=bool)
        for c, limit in zip(columns, max_abs, strict=True):
            flat = c.reshape(m, -1)
            # The min/max test needs no N-sized temporary; the per-sample mask only when a value is out of range.
            if limit is not None and flat.size and (flat.max() > limit or flat.min() < -limit):
                plausible &= (np.abs(flat) <= limit).all(axis=1)
        report.n_implausible = int(m - np.count_nonzero(plausible))
        if report.n_implausible > MAX_IMPLAUSIBLE_FRACTION * m:
            raise QualityError(
                f"{report.n_implausible} of {m} samples exceed the physical limits {tuple(max_abs[:n_data])} "
                "(wrong units, or corrupt data)"
            )
        if report.n_implausible:
            t, columns = t[plausible], _take(columns, plausible)

    zero = t == 0.0
    n_zero = int(np.count_nonzero(zero))
    if 0 < n_zero < t.shape[0] and t[~zero].min() > ZERO_STAMP_CLOCK_S:
        report.n_zero_stamps = n_zero
        t, columns = t[~zero], _take(columns, ~zero)

    glitch = _glitches(t)
    report.n_glitches = int(np.count_nonzero(glitch))
    if report.n_glitches:
        t, columns = t[~glitch], _take(columns, ~glitch)

    steps = np.diff(t)
    report.n_backwards = int(np.count_nonzero(steps < 0))
    if report.n_backwards:
        order = np.argsort(t, kind="stable")
        t, columns = t[order], _take(columns, order)
        steps = np.diff(t)

    repeated = steps == 0
    report.n_duplicates = int(np.count_nonzero(repeated))
    if report.n_duplicates:
        keep = np.concatenate(([True], ~repeated))
        t, columns = t[keep], _take(columns, keep)
        steps = np.diff(t)

    report.n_output = int(t.shape[0])
    if report.n_output < min_samples:
        raise QualityError(
            f"only {report.n_output} usable sample(s) of {n} after dropping bad ones; need at least {min_samples}"
        )
    report.positions = columns[n_data]
    report.period = estimate_period(t, index=report.positions,
                                    receive=columns[n_data + 1] if receive is not None else None,
                                    declared_hz=declared_hz)
    report.gaps = find_gaps(t, report.period, gap_factor)
    report.t0 = float(t[0])
    columns = columns[:n_data]
    return t, (columns[0] if single else columns), report



def interpolate_missing(y: np.ndarray) -> np.ndarray:
    """``y`` with NaN samples interpolated linearly (held at the ends)."""
    bad = ~np.isfinite(y)
    if not bad.any():
        return y
    idx = np.arange(y.size)
    out = np.array(y, dtype=float)
    out[bad] = np.interp(idx[bad], idx[~bad], y[~bad])
    return out
