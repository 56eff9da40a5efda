"""Checks and documented repairs of sampled time series (pure numpy; shared by the bag reader and the node).

Repairs done by :func:`repair_time_series`, in this order, each counted in the returned :class:`QualityReport`:

1. drop samples whose time or any value is NaN/±inf, or whose magnitude exceeds a physical limit (``max_abs``,
   e.g. :data:`IMU_MAX_ABS`: such values come from corrupt bytes or wrong units; more than
   :data:`MAX_IMPLAUSIBLE_FRACTION` of them raise instead of being dropped);
2. drop samples with a zero stamp when the other stamps are clock times (> :data:`ZERO_STAMP_CLOCK_S`),
   i.e. the publisher left ``header.stamp`` unset for them, and samples whose stamp jumps away from both its
   neighbours in message order by more than :data:`GLITCH_PERIODS` periods while the neighbours agree (one stamp
   an hour in the future or the past: a clock glitch, not a gap);
3. sort by time (stable) when stamps go backwards;
4. drop samples whose stamp equals the previous one (the first is kept);
5. estimate the sampling period from the stamps, the messages' positions and the receive times
   (:func:`imu_noise_id.core.timing.estimate_period`: bursty host stamps, holes left by the drops);
6. find gaps: intervals longer than ``gap_factor`` × the period (bursty stamps: × their 99th-percentile interval).
   Gaps are reported, not filled.

:func:`static_check` flags data that is clearly not from a static sensor (for the static noise analyses).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .axes import AXES, ImuSeries
from .errors import InputError
from .timing import SamplePeriod, estimate_period

#: Stamps are clock (epoch) times if the smallest non-zero one exceeds this [s]; zero stamps among them are unset.
ZERO_STAMP_CLOCK_S = 60.0
#: A stamp this many periods away from both message neighbours (which agree with each other) is a clock glitch.
GLITCH_PERIODS = 100
#: A gap is an interval longer than this many periods.
GAP_FACTOR = 1.5
#: Standard gravity [m/s²], as in :mod:`.simulate` (not imported from there: it would pull in scipy, ~80 MB of
#: memory, into the bag reader).
STANDARD_GRAVITY = 9.80665
#: No IMU measures more than this: (gyro [rad/s] ≈ 57 000 °/s, accel [m/s²] ≈ 1000 g).
IMU_MAX_ABS: tuple[float, float] = (1e3, 1e4)
#: Above this fraction of impossible values the series is rejected rather than repaired.
MAX_IMPLAUSIBLE_FRACTION = 0.01
#: At most this many gaps are listed one by one in the notes.
MAX_LISTED_GAPS = 10


class QualityError(InputError):
    """The series cannot be repaired into something usable (e.g. no finite sample, fewer than two samples)."""


@dataclass
class QualityReport:
    """What :func:`repair_time_series` found and did.

    Attributes
    ----------
    n_input, n_output : samples before and after the repairs
    n_nonfinite : samples dropped because the time or a value was NaN/±inf
    n_implausible : samples dropped because a value exceeded its physical limit
    n_zero_stamps : samples dropped because their stamp was 0 among clock-time stamps
    n_glitches : samples dropped because their stamp jumped away from both neighbours (see the module docstring)
    n_backwards : places where the stamp decreased (the series was sorted if > 0)
    n_duplicates : samples dropped because their stamp repeated the previous one
    period : the sampling period after the repairs, how it was obtained and what the stamps' trust is (None
        before it is estimated)
    positions : (n_output,) each kept sample's position among the input samples (message order)
    gaps : (start time [s], length [s], estimated missing samples) of every gap, in time order
    t0 : first stamp after the repairs [s] (gap start times in notes are given relative to it)
    """

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
        """Human-readable notes, one per finding (empty when the series was clean)."""
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
    """Intervals of sorted stamps ``t`` longer than ``gap_factor`` × the period (bursty stamps: × their 99th
    percentile interval, as their normal delivery pauses are longer than the period): (start [s], length [s],
    missing samples)."""
    dt = period.value if isinstance(period, SamplePeriod) else float(period)
    if t.shape[0] < 2 or not dt > 0:
        return []
    steps = np.diff(t)
    reference = max(dt, float(np.quantile(steps, 0.99))) if isinstance(period, SamplePeriod) and period.bursty \
        else dt
    where = np.flatnonzero(steps > gap_factor * reference)
    return [(float(t[i]), float(steps[i]), max(round(steps[i] / dt) - 1, 1)) for i in where]


def _glitches(t: np.ndarray) -> np.ndarray:
    """Samples (in message order) whose stamp is more than :data:`GLITCH_PERIODS` periods from both neighbours'
    while the neighbours are within a tenth of that of each other (few N-sized temporaries: one diff, two masks)."""
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
    """Drop bad samples, sort, drop duplicates, estimate the period and find gaps (rules: module docstring).

    Parameters
    ----------
    t : (N,) stamps [s]
    data : (N, ...) array, or a sequence of such arrays sharing the first dimension (e.g. gyro and accel)
    gap_factor : an interval longer than ``gap_factor`` × the period is a gap
    min_samples : fewer valid samples than this raise :class:`QualityError`
    max_abs : per data array, the largest plausible magnitude (None: no limit), e.g. :data:`IMU_MAX_ABS` for
        (gyro, accel)
    receive : (N,) the bag's receive times [s] of the samples (a second clock for the period), or None
    declared_hz : the rate the user declares (``--rate``), or None

    Returns
    -------
    t, data, report
        Repaired copies (or the inputs themselves when nothing had to change; ``data`` in the same form as given)
        and what was done (with the period and each kept sample's input position).

    Raises
    ------
    QualityError
        If fewer than ``min_samples`` samples remain (e.g. every sample is NaN), or more than
        :data:`MAX_IMPLAUSIBLE_FRACTION` of the finite samples exceed ``max_abs``.
    InputError
        A declared rate that is not a positive number.
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
    """``y`` with its NaN samples linearly interpolated from their neighbours (held at the ends); ``y`` itself when
    nothing is missing. For estimators that need a gap-free series (the Allan variance, the periodogram)."""
    bad = ~np.isfinite(y)
    if not bad.any():
        return y
    idx = np.arange(y.size)
    out = np.array(y, dtype=float)
    out[bad] = np.interp(idx[bad], idx[~bad], y[~bad])
    return out


# --- static check -------------------------------------------------------------------------------------------

#: |mean specific force| may differ from standard gravity by this much without comment [m/s²] (local gravity spans
#: 9.78–9.83 m/s²); a larger difference within :data:`GRAVITY_SCALE_TOLERANCE` is noted (scale or bias error).
GRAVITY_TOLERANCE = 0.3
#: Relative difference of |mean specific force| from gravity beyond which the record is not a static IMU reading
#: gravity in m/s² (gravity removed, g units, or strong motion); consumer accelerometers err by a few % at most.
GRAVITY_SCALE_TOLERANCE = 0.10
#: Standard deviation of 1 s means above which a gyro axis is rotating rather than drifting [rad/s] (≈0.6 °/s).
GYRO_BLOCK_STD_MAX = 0.01
#: Standard deviation of 1 s means above which an accelerometer axis is moving or tilting [m/s²].
ACCEL_BLOCK_STD_MAX = 0.05
#: Length of the blocks whose means reveal low-frequency motion [s].
BLOCK_S = 1.0


#: Motion bursts: the spread of the samples is measured in windows of this length [s] …
BURST_WINDOW_S = 0.25
#: … as the mean square deviation from the window's median of all but this share of its samples (the largest
#: deviations: a few spikes in a window are outliers, not motion) …
BURST_TRIM = 0.1
#: … and a burst is a stretch of at least :data:`BURST_MIN_S` [s] whose windows all spread this many times more
#: than the record's median window on some axis: a touch, a knock, the start of a motion. On the real records of
#: ``../shared/data`` (``bench/bench_motion_bursts.py``) the still ones stay at 8.3 or below (ADIS16405 runs 1–6,
#: 2.8 h each, but for run 4; the MTi-G gyro; the BROAD rest phases), run 4's accel_y reaches 11.5, and so does the
#: motion's settling in the 35 s BROAD trial 10 marks as rest after it; the knocks in ADIS16405 run 4 (accel_z, t ≈
#: 4046 s and 5146 s, ±5 m/s² for 0.4 s) reach 36–48 and the 1.3 s of motion that trial 10's rest before its motion
#: still holds reach 136. The threshold flags what is clearly motion.
BURST_RATIO = 25.0
BURST_MIN_S = 0.5
#: The still stretch suggested in place of a record with bursts keeps this far [s] from them.
STILL_MARGIN_S = 1.0


@dataclass(frozen=True)
class MotionBurst:
    """A stretch where the samples spread far wider than over the rest of the record (:func:`motion_bursts`).

    Attributes
    ----------
    start_s, end_s : the stamps of its first and last sample, from the first sample's [s]
    axes : the axes that burst
    ratio : the largest sustained spread ratio over those axes (the smallest window ratio of the burst's windows)
    """

    start_s: float
    end_s: float
    axes: tuple[str, ...]
    ratio: float


@dataclass
class StaticCheck:
    """What :func:`static_check` found: ``flags`` (reasons the record is not static), ``notes`` (worth knowing,
    not signs of motion), the motion ``bursts`` and, when there are some, the longest ``still_span`` between them
    (start, end [s] from the first sample, :data:`STILL_MARGIN_S` away from them)."""

    flags: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    bursts: list[MotionBurst] = field(default_factory=list)
    still_span: tuple[float, float] | None = None

    @property
    def static(self) -> bool:
        return not self.flags


def _block_means(x: np.ndarray, samples_per_block: int) -> np.ndarray:
    """Means of consecutive blocks of a 1-D array (a strided view is reshaped without a copy)."""
    m = x.shape[0] // samples_per_block
    return x[: m * samples_per_block].reshape(m, samples_per_block).mean(axis=1)


def burst_window(dt: float) -> tuple[int, int]:
    """(samples per :data:`BURST_WINDOW_S` window, windows per :data:`BURST_MIN_S` burst) at period ``dt`` [s]."""
    width = max(round(BURST_WINDOW_S / dt), 8)
    return width, max(round(BURST_MIN_S / (width * dt)), 2)


def spread_ratios(x: np.ndarray, dt: float) -> np.ndarray:
    """Per :func:`burst_window` window of ``x``: the mean square deviation from the window's median of its samples
    but the :data:`BURST_TRIM` share that deviate most, over the median of that over the windows; zeros when that
    median is 0 (most windows on one quantisation level: no scale to judge the axis by)."""
    width = burst_window(dt)[0]
    m = x.shape[0] // width
    windows = x[: m * width].reshape(m, width)
    dev = np.abs(windows - np.median(windows, axis=1, keepdims=True))
    dev.sort(axis=1)
    spread = np.mean(dev[:, : width - int(BURST_TRIM * width)] ** 2, axis=1)
    level = float(np.median(spread)) if m else 0.0
    return spread / level if level > 0 else np.zeros(m)


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last + 1) of every run of True in ``mask``."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], mask.astype(np.int8), [0]))))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def motion_bursts(imu: ImuSeries, dt: float) -> list[MotionBurst]:
    """Stretches of at least :data:`BURST_MIN_S` where on some axis every :data:`BURST_WINDOW_S` window's spread
    is :data:`BURST_RATIO` or more times the record's median window spread (:func:`spread_ratios`); overlapping or
    touching stretches of several axes are one burst. Motion that lasts a moment (a touch, a knock, a cut made a
    second late) changes the record's Allan variance little over hours, but the model stage and the closed loop
    fit it (as oscillations, outliers, a random walk), and so do N and K. ``dt``: the sampling period [s]."""
    width, needed = burst_window(dt)
    if len(imu) // width < 2 * needed:
        return []
    ratio = np.array([spread_ratios(imu.gyro[:, i] if i < 3 else imu.accel[:, i - 3], dt) for i in range(len(AXES))])
    m = ratio.shape[1]
    bursting = np.zeros((len(AXES), m), bool)
    for i in range(len(AXES)):
        for a, b in _runs(ratio[i] >= BURST_RATIO):
            if b - a >= needed:
                bursting[i, a:b] = True
    out = []
    for a, b in _runs(bursting.any(axis=0)):
        axes = tuple(name for i, name in enumerate(AXES) if bursting[i, a:b].any())
        sustained = max(float(np.min(ratio[i, a:b][bursting[i, a:b]])) for i in range(len(AXES))
                        if bursting[i, a:b].any())
        elapsed = imu.t[[a * width, b * width - 1]] - imu.t[0]  # the stamps: the times a span selects by
        out.append(MotionBurst(float(elapsed[0]), float(elapsed[1]), axes, sustained))
    return out


def still_span(bursts: list[MotionBurst], duration_s: float) -> tuple[float, float] | None:
    """The longest stretch of a record of ``duration_s`` [s] between ``bursts``, :data:`STILL_MARGIN_S` away from
    them (not from the record's ends); None without bursts or when no stretch is left."""
    if not bursts:
        return None
    edges = [0.0, *[x for b in bursts for x in (b.start_s - STILL_MARGIN_S, b.end_s + STILL_MARGIN_S)], duration_s]
    spans = [(edges[k], edges[k + 1]) for k in range(0, len(edges), 2) if edges[k + 1] > edges[k]]
    return max(spans, key=lambda span: span[1] - span[0]) if spans else None


def static_check(imu: ImuSeries, dt: float | None = None, gravity: float = STANDARD_GRAVITY) -> StaticCheck:
    """Whether ``imu`` looks like a static recording, judged by what motion does.

    Flags, with the thresholds of this module (documented constants):

    - ``|mean(accel)|`` differs from ``gravity`` by more than :data:`GRAVITY_SCALE_TOLERANCE` (relative): gravity
      removed, accelerometer not in m/s², or the IMU is not at rest; a smaller difference beyond
      :data:`GRAVITY_TOLERANCE` is a note (an uncalibrated accelerometer's scale or bias);
    - the standard deviation of :data:`BLOCK_S`-long block means exceeds :data:`GYRO_BLOCK_STD_MAX` (gyro) or
      :data:`ACCEL_BLOCK_STD_MAX` (accel) on some axis, or the block means of |accel| vary by more than
      :data:`ACCEL_BLOCK_STD_MAX`: the sensor rotates, moves, tilts or is shaken;
    - motion bursts (:func:`motion_bursts`): a moment of motion in an otherwise still record, which block means
      of a second average away; the longest still stretch between them is suggested (:func:`still_span`).

    Low-frequency power is what motion adds. The noise's own colour is not: a sensor whose internal low-pass filter
    (a DLPF) smooths its white noise is still static, so no test compares the variance with a first-difference
    noise floor. These are heuristics for *clearly* non-static data; a static analysis should warn, not silently
    proceed.
    """
    n = len(imu)
    if n < 20:
        return StaticCheck([f"only {n} samples: too short to check that the IMU was static"])
    out = StaticCheck()
    g_mean = float(np.linalg.norm(imu.accel.mean(axis=0)))
    off = g_mean - gravity
    if abs(off) > GRAVITY_SCALE_TOLERANCE * gravity:
        out.flags.append(
            f"|mean accel| = {g_mean:.3f} m/s² but a static IMU reads gravity ≈ {gravity:.3f} m/s² (tolerance "
            f"{100 * GRAVITY_SCALE_TOLERANCE:g} %): the IMU moves, its accel is not in m/s², or gravity was removed"
        )
    elif abs(off) > GRAVITY_TOLERANCE:
        out.notes.append(
            f"|mean accel| = {g_mean:.3f} m/s² is {100 * off / gravity:+.1f} % from standard gravity: the "
            "accelerometer's scale or bias is uncalibrated (not a sign of motion)"
        )
    dt = imu.dt if dt is None else dt
    per_block = min(max(round(BLOCK_S / dt), 1), n // 10)
    # One axis at a time (strided views, no (N, 6) copy): a few N-sized temporaries at most.
    for i, name in enumerate(AXES):
        x = imu.gyro[:, i] if i < 3 else imu.accel[:, i - 3]
        limit, unit = (GYRO_BLOCK_STD_MAX, "rad/s") if i < 3 else (ACCEL_BLOCK_STD_MAX, "m/s²")
        block_std = float(_block_means(x, per_block).std())
        if block_std > limit:
            out.flags.append(
                f"{name}: the {per_block * dt:.3g} s means vary with std {block_std:.3g} {unit} "
                f"(> {limit} {unit}): the IMU rotates, moves or tilts"
            )
    norm_std = float(_block_means(np.linalg.norm(imu.accel, axis=1), per_block).std())
    if norm_std > ACCEL_BLOCK_STD_MAX:
        out.flags.append(
            f"|accel|: the {per_block * dt:.3g} s means vary with std {norm_std:.3g} m/s² (> {ACCEL_BLOCK_STD_MAX} "
            "m/s²): the IMU is accelerated or shaken"
        )
    out.bursts = motion_bursts(imu, dt)
    if out.bursts:
        listed = ", ".join(f"{b.start_s:.1f}–{b.end_s:.1f} s ({', '.join(b.axes)}; {b.ratio:.0f}×)"
                           for b in out.bursts[:MAX_LISTED_GAPS])
        more = f" and {len(out.bursts) - MAX_LISTED_GAPS} more" if len(out.bursts) > MAX_LISTED_GAPS else ""
        out.flags.append(
            f"motion bursts at t = {listed}{more} from the first sample: for {BURST_MIN_S:g} s or more the samples "
            f"spread at least {BURST_RATIO:g}× wider than over the record ({BURST_WINDOW_S:g} s windows): the IMU "
            "was moved, touched or knocked"
        )
        out.still_span = still_span(out.bursts, float(imu.t[-1] - imu.t[0]))
    return out
