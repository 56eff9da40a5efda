"""Whether a recording is from a still sensor, judged by what motion does (docs/bags.md, "Static check")."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .axes import AXES, GYRO_AXES, ImuSeries
from .constants import STANDARD_GRAVITY

#: |mean specific force| may differ from standard gravity by this much without a note [m/s²].
GRAVITY_TOLERANCE = 0.3
#: Relative difference of |mean specific force| from gravity beyond which the record is not a static IMU reading
#: gravity in m/s².
GRAVITY_SCALE_TOLERANCE = 0.10
#: Standard deviation of 1 s means above which a gyro axis is rotating rather than drifting [rad/s] (≈0.6 °/s).
GYRO_BLOCK_STD_MAX = 0.01
#: Standard deviation of 1 s means above which an accelerometer axis is moving or tilting [m/s²].
ACCEL_BLOCK_STD_MAX = 0.05
#: Length of the blocks whose means reveal low-frequency motion [s].
BLOCK_S = 1.0


#: Motion bursts: the spread of the samples is measured in windows of this length [s] …
BURST_WINDOW_S = 0.25
#: … as the mean square deviation from the window's median of all but this share of its samples (the largest) …
BURST_TRIM = 0.1
#: … and a burst is a stretch of at least :data:`BURST_MIN_S` [s] whose windows all spread this many times more
#: than the record's median window on some axis.
BURST_RATIO = 25.0
BURST_MIN_S = 0.5
#: The still stretch suggested in place of a record with bursts keeps this far [s] from them.
STILL_MARGIN_S = 1.0
#: At most this many bursts are listed one by one in the flag.
MAX_LISTED_BURSTS = 10
#: The longest stretch of at least :data:`QUIET_MIN_S` [s] whose :data:`BLOCK_S` means stay within this many times
#: the block tests' limits of each other, on every axis, and that passes those tests is the still stretch.
QUIET_RANGE = 2.0
QUIET_MIN_S = 10.0


@dataclass(frozen=True)
class MotionBurst:
    """A stretch of far wider spread: ``start_s``, ``end_s`` [s from the first sample], ``axes``, ``ratio``."""

    start_s: float
    end_s: float
    axes: tuple[str, ...]
    ratio: float


@dataclass
class StaticCheck:
    """:func:`static_check`'s ``flags``, ``notes``, ``bursts`` and ``still_span`` (start, end [s]) or None."""

    flags: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    bursts: list[MotionBurst] = field(default_factory=list)
    still_span: tuple[float, float] | None = None

    @property
    def static(self) -> bool:
        return not self.flags

    def refusal(self, topic: str | None, *, needs: str, verb: str, origin_s: float = 0.0) -> str:
        """The message refusing a recording with these flags: ``topic`` does not look static (the flags, their times
        said to be from the analysed span's first sample, ``origin_s`` [s] into the record, when above 0), why it
        ``needs`` the IMU at rest, how to ``verb`` anyway (allow_motion) and, where there is one, how to ``verb`` the
        longest still stretch alone (span, ``origin_s`` added: times from the record's first sample)."""
        within = "" if origin_s == 0.0 else (f" (the times above are from the analysed span's first sample, "
                                             f"{origin_s:g} s into the record)")
        still = "" if self.still_span is None else (
            f"; or {verb} its longest still stretch alone: "
            + "span=({0:.1f}, {1:.1f}) (CLI: --span {0:.1f}:{1:.1f})".format(*(origin_s + t for t in self.still_span)))
        return (f"{topic or 'input'} does not look static: " + "; ".join(self.flags) + within
                + f". {needs}; pass allow_motion (CLI: --allow-motion) to {verb} anyway" + still)


def _windows(x: np.ndarray, width: int) -> np.ndarray:
    m = x.shape[0] // width
    return x[: m * width].reshape(m, width)


def burst_window(dt: float) -> tuple[int, int]:
    """(samples per :data:`BURST_WINDOW_S` window, windows per :data:`BURST_MIN_S` burst) at period ``dt`` [s]."""
    width = max(round(BURST_WINDOW_S / dt), 8)
    return width, max(round(BURST_MIN_S / (width * dt)), 2)


def spread_ratios(x: np.ndarray, dt: float) -> np.ndarray:
    """Per burst window: trimmed mean square deviation from its median over the windows' median (0 if 0)."""
    width = burst_window(dt)[0]
    windows = _windows(x, width)
    m = windows.shape[0]
    dev = np.abs(windows - np.median(windows, axis=1, keepdims=True))
    dev.sort(axis=1)
    spread = np.mean(dev[:, : width - int(BURST_TRIM * width)] ** 2, axis=1)
    level = float(np.median(spread)) if m else 0.0
    return spread / level if level > 0 else np.zeros(m)


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    edges = np.flatnonzero(np.diff(np.concatenate(([0], mask.astype(np.int8), [0]))))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def motion_bursts(imu: ImuSeries, dt: float, axes: tuple[str, ...] = AXES) -> list[MotionBurst]:
    """Stretches ≥ :data:`BURST_MIN_S` whose windows spread ≥ :data:`BURST_RATIO` × the median on one of ``axes``."""
    width, needed = burst_window(dt)
    if len(imu) // width < 2 * needed:
        return []
    ratio = np.array([spread_ratios(imu.axis(name), dt) for name in axes])
    m = ratio.shape[1]
    bursting = np.zeros((len(axes), m), bool)
    for i in range(len(axes)):
        for a, b in _runs(ratio[i] >= BURST_RATIO):
            if b - a >= needed:
                bursting[i, a:b] = True
    out = []
    for a, b in _runs(bursting.any(axis=0)):
        moved = tuple(name for i, name in enumerate(axes) if bursting[i, a:b].any())
        sustained = max(float(np.min(ratio[i, a:b][bursting[i, a:b]])) for i in range(len(axes))
                        if bursting[i, a:b].any())
        elapsed = imu.t[[a * width, b * width - 1]] - imu.t[0]  # the stamps: the times a span selects by
        out.append(MotionBurst(float(elapsed[0]), float(elapsed[1]), moved, sustained))
    return out


def still_span(imu: ImuSeries, bursts: list[MotionBurst], dt: float, gravity: float = STANDARD_GRAVITY,
               axes: tuple[str, ...] = AXES) -> tuple[float, float] | None:
    """The longest still stretch (start, end [s] from the first sample) between ``bursts``, :data:`STILL_MARGIN_S`
    from them, that passes the block tests, or the longest :func:`quiet_span` within such a gap; at least
    :data:`QUIET_MIN_S` long; None if none. A gap between knocks can still move slowly (a robot driving between two
    bumps), and a span offered must pass the check it is offered to."""
    duration_s = float(imu.t[-1] - imu.t[0])
    edges = [0.0, *[x for b in bursts for x in (b.start_s - STILL_MARGIN_S, b.end_s + STILL_MARGIN_S)], duration_s]
    gaps = sorted(((edges[k], edges[k + 1]) for k in range(0, len(edges), 2) if edges[k + 1] - edges[k] >= QUIET_MIN_S),
                  key=lambda gap: gap[0] - gap[1])  # the longest first
    best: tuple[float, float] | None = None
    for lo, hi in gaps:
        if best is not None and hi - lo <= best[1] - best[0]:
            break
        part = imu.between(lo, hi)
        origin = float(part.t[0] - imu.t[0])
        if not _block_flags(part, dt, gravity, axes):
            found: tuple[float, float] | None = (lo, hi)
        else:
            quiet = quiet_span(part, dt, gravity, axes)
            found = None if quiet is None else (origin + quiet[0], origin + quiet[1])
        if found is not None and (best is None or found[1] - found[0] > best[1] - best[0]):
            best = found
    return best


def quiet_span(imu: ImuSeries, dt: float, gravity: float = STANDARD_GRAVITY,
               axes: tuple[str, ...] = AXES) -> tuple[float, float] | None:
    """The longest still stretch (start, end [s]) of ≥ :data:`QUIET_MIN_S` by the block tests within
    :data:`QUIET_RANGE`, off motion by a block and :data:`STILL_MARGIN_S`; or None."""
    n = len(imu)
    per_block = max(round(BLOCK_S / dt), 1)
    if n // per_block < 2:
        return None
    accel = _has_accelerometer(axes)
    means = np.array([_windows(imu.axis(name), per_block).mean(axis=1) for name in axes]
                     + ([_windows(np.linalg.norm(imu.accel, axis=1), per_block).mean(axis=1)] if accel else []))
    limits = QUIET_RANGE * np.array([GYRO_BLOCK_STD_MAX if name in GYRO_AXES else ACCEL_BLOCK_STD_MAX
                                     for name in axes] + ([ACCEL_BLOCK_STD_MAX] if accel else []))[:, None]
    best, lo = (0, 0), 0
    for hi in range(means.shape[1]):
        while np.any(np.ptp(means[:, lo:hi + 1], axis=1, keepdims=True) > limits):
            lo += 1
        if hi + 1 - lo > best[1] - best[0]:
            best = (lo, hi + 1)
    start, end = (float(v) for v in imu.t[[best[0] * per_block, best[1] * per_block - 1]] - imu.t[0])
    # a motion's onset hides in the last block that still passed: keep a block and the margin away from it
    start += (STILL_MARGIN_S + BLOCK_S) if best[0] > 0 else 0.0
    end -= (STILL_MARGIN_S + BLOCK_S) if best[1] < means.shape[1] else 0.0
    if end - start < QUIET_MIN_S or _block_flags(imu.between(start, end), dt, gravity, axes):
        return None
    return start, end


def _has_accelerometer(axes: tuple[str, ...]) -> bool:
    """Whether ``axes`` hold an accelerometer axis (the gravity and |accel| tests need one)."""
    return any(name not in GYRO_AXES for name in axes)


def _block_flags(imu: ImuSeries, dt: float, gravity: float, axes: tuple[str, ...] = AXES) -> list[str]:
    flags = []
    accel = _has_accelerometer(axes)  # the gravity and |accel| tests need the accelerometer
    g_mean = float(np.linalg.norm(imu.accel.mean(axis=0)))
    if accel and abs(g_mean - gravity) > GRAVITY_SCALE_TOLERANCE * gravity:
        flags.append(
            f"|mean accel| = {g_mean:.3f} m/s² but a static IMU reads gravity ≈ {gravity:.3f} m/s² (tolerance "
            f"{100 * GRAVITY_SCALE_TOLERANCE:g} %): the IMU moves, its accel is not in m/s², or gravity was removed"
        )
    n = len(imu)
    per_block = min(max(round(BLOCK_S / dt), 1), n // 10)
    # One axis at a time (strided views, no (N, 6) copy): a few N-sized temporaries at most.
    for name in axes:
        limit, unit = (GYRO_BLOCK_STD_MAX, "rad/s") if name in GYRO_AXES else (ACCEL_BLOCK_STD_MAX, "m/s²")
        block_std = float(_windows(imu.axis(name), per_block).mean(axis=1).std())
        if block_std > limit:
            flags.append(
                f"{name}: the {per_block * dt:.3g} s means vary with std {block_std:.3g} {unit} "
                f"(> {limit} {unit}): the IMU rotates, moves or tilts"
            )
    norm_std = float(_windows(np.linalg.norm(imu.accel, axis=1), per_block).mean(axis=1).std()) if accel else 0.0
    if norm_std > ACCEL_BLOCK_STD_MAX:
        flags.append(
            f"|accel|: the {per_block * dt:.3g} s means vary with std {norm_std:.3g} m/s² (> {ACCEL_BLOCK_STD_MAX} "
            "m/s²): the IMU is accelerated or shaken"
        )
    return flags


def static_check(imu: ImuSeries, dt: float | None = None, gravity: float = STANDARD_GRAVITY,
                 axes: tuple[str, ...] = AXES) -> StaticCheck:
    """Flags of a clearly non-static ``imu`` judged on ``axes`` (the gravity and |accel| tests only with an
    accelerometer axis among them): |mean accel| beyond :data:`GRAVITY_SCALE_TOLERANCE` of ``gravity``
    (beyond :data:`GRAVITY_TOLERANCE`: a note), 1 s means wandering (:data:`GYRO_BLOCK_STD_MAX`,
    :data:`ACCEL_BLOCK_STD_MAX`), motion bursts; the still or quiet span."""
    n = len(imu)
    if n < 20:
        return StaticCheck([f"only {n} samples: too short to check that the IMU was static"])
    dt = imu.dt if dt is None else dt
    out = StaticCheck(flags=_block_flags(imu, dt, gravity, axes))
    g_mean = float(np.linalg.norm(imu.accel.mean(axis=0)))
    off = g_mean - gravity
    if _has_accelerometer(axes) and GRAVITY_TOLERANCE < abs(off) <= GRAVITY_SCALE_TOLERANCE * gravity:
        out.notes.append(
            f"|mean accel| = {g_mean:.3f} m/s² is {100 * off / gravity:+.1f} % from standard gravity: the "
            "accelerometer's scale or bias is uncalibrated (not a sign of motion)"
        )
    out.bursts = motion_bursts(imu, dt, axes)
    if out.bursts:
        listed = ", ".join(f"{b.start_s:.1f}–{b.end_s:.1f} s ({', '.join(b.axes)}; {b.ratio:.0f}×)"
                           for b in out.bursts[:MAX_LISTED_BURSTS])
        more = f" and {len(out.bursts) - MAX_LISTED_BURSTS} more" if len(out.bursts) > MAX_LISTED_BURSTS else ""
        out.flags.append(
            f"motion bursts at t = {listed}{more} from the first sample: for {BURST_MIN_S:g} s or more the samples "
            f"spread at least {BURST_RATIO:g}× wider than over the record ({BURST_WINDOW_S:g} s windows): the IMU "
            "was moved, touched or knocked"
        )
        out.still_span = still_span(imu, out.bursts, dt, gravity, axes)
    elif out.flags:
        out.still_span = quiet_span(imu, dt, gravity, axes)
    return out
