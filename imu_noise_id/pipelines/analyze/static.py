"""The Allan stage of ``analyze``: :func:`analyze_static` checks a static recording (:data:`MIN_SAMPLES`, finite values,
the sampling period by :mod:`imu_noise_id.core.timing`, missing samples,
:func:`imu_noise_id.core.stillness.static_check`: non-static data raise unless ``allow_motion``), computes the Allan
family per axis (:func:`imu_noise_id.core.allan.allan_family`) and the Allan-slope parameters
(:func:`imu_noise_id.core.allan.slopes.fit_axis_slopes`, warned about where only an upper bound), into a
:class:`StaticAnalysis`."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ...core.allan import DEFAULT_CONFIDENCE, DEFAULT_PER_DECADE, KINDS, AllanResult, allan_family, stack_axes
from ...core.allan.slopes import AxisSlopes, fit_axis_slopes
from ...core.axes import ACCEL_AXES, GYRO_AXES, ImuSeries
from ...core.errors import InputError
from ...core.stillness import static_check
from ...core.timing import SamplePeriod

#: Fewer samples than this cannot give a useful Allan curve (a few decades of τ).
MIN_SAMPLES = 100
#: Relative spread of the sampling intervals tolerated before the analysis warns about timing.
JITTER_WARN = 0.05
#: Fraction of the sensor's samples missing above which the analysis warns that time-dependent terms are distorted.
MISSING_WARN = 0.01


class NotStaticError(InputError):
    """The recording is clearly not static; the message lists why and how to override."""


@dataclass
class StaticAnalysis:
    """Result of :func:`analyze_static`.

    Attributes
    ----------
    axes : tuple of str
        Axis names, the column order of every per-axis array.
    n, dt, duration_s : int, float, float
        Samples per axis, sampling period [s] (``period.value``), n·dt [s].
    topic : str
        Where the samples came from.
    variances : dict of str to AllanResult
        Allan-family results by kind (always ``"allan"``), each (T, 6).
    slopes : dict of str to AxisSlopes
        Allan-slope parameters per axis.
    warnings : list of str
        Problems found (timing, motion, bounds) and the input's notes.
    period : SamplePeriod or None
        How the period was obtained.
    missing : int
        Samples the sensor produced within the record but the series lacks.
    """

    axes: tuple[str, ...]
    n: int
    dt: float
    duration_s: float
    topic: str
    variances: dict[str, AllanResult]
    slopes: dict[str, AxisSlopes]
    warnings: list[str] = field(default_factory=list)
    period: SamplePeriod | None = None
    missing: int = 0

    @property
    def allan(self) -> AllanResult:
        """The Allan variance (T, 6)."""
        return self.variances["allan"]

    @property
    def rate_hz(self) -> float:
        """Sampling rate [Hz]."""
        return 1.0 / self.dt


def missing_samples(t: np.ndarray, dt: float) -> int:
    """Samples a sensor at period ``dt`` produced between the first and last stamps that ``t`` lacks."""
    return max(0, round((t[-1] - t[0]) / dt) + 1 - t.shape[0])


def _timing_warnings(imu: ImuSeries, period: SamplePeriod) -> tuple[list[str], int]:
    """Warnings about the timing the analysis relies on, and the number of missing samples."""
    t = imu.t
    steps = np.diff(t)
    if np.any(steps <= 0):
        raise InputError(
            "sample times are not strictly increasing: sort the samples and drop duplicated stamps first "
            "(the bag reader does this and notes it)"
        )
    warnings = [w for w in period.warnings if w not in " ".join(imu.notes)]
    dt = period.value
    missing = 0 if period.bursty else missing_samples(t, dt)
    fraction = missing / (missing + t.shape[0])
    if fraction > MISSING_WARN:
        warnings.append(
            f"{missing} samples ({100 * fraction:.1f} % of the record at {1 / dt:.6g} Hz) are missing (dropped or "
            "lost): the Allan estimators and the models take the remaining samples as consecutive at the period, "
            "which keeps the white noise right but shortens time: the random walk and other slow terms come out "
            f"up to {1 / np.sqrt(1 - fraction):.3g}x too large"
        )
    elif missing:
        warnings.append(
            f"{missing} missing sample(s) (gaps): the Allan estimators treat the samples as equally spaced, so τ "
            "near and above the gaps is slightly distorted"
        )
    if not period.bursty:
        spread = float(np.std(steps[steps < 1.5 * dt]) / dt) if np.any(steps < 1.5 * dt) else 0.0
        if spread > JITTER_WARN:
            warnings.append(
                f"sampling intervals vary by {100 * spread:.1f} % (std/period): short-τ Allan values are less reliable"
            )
    return warnings, missing


def _slope_warnings(name: str, slopes: AxisSlopes, duration_s: float) -> list[str]:
    warnings = []
    if slopes.noise_density.method == "upper_bound":
        warnings.append(f"{name}: no white-noise (−½) region on the Allan curve; noise density is an upper bound")
    if slopes.random_walk.method == "upper_bound":
        warnings.append(
            f"{name}: the random-walk (+½) slope is not reached within {duration_s:.0f} s; the random walk is an "
            "upper bound. Record longer (several times the τ where the curve bottoms out)"
        )
    return warnings


def analyze_static(
    imu: ImuSeries,
    *,
    kinds: Sequence[str] = KINDS,
    per_decade: int = DEFAULT_PER_DECADE,
    confidence: float = DEFAULT_CONFIDENCE,
    allow_motion: bool = False,
    progress: Callable[[int, int], None] | None = None,
    sensors: tuple[str, ...] = ("gyro", "accel"),
    origin_s: float = 0.0,
) -> StaticAnalysis:
    """Allan-family variances and Allan-slope noise parameters of a static IMU recording.

    Parameters
    ----------
    imu : ImuSeries
        Samples of all six axes (rad/s, m/s²) at a constant period.
    kinds : sequence of str
        Allan-family variances to compute ("allan" is always included).
    per_decade : int
        Averaging times per decade.
    confidence : float
        Two-sided level of the confidence intervals.
    allow_motion : bool
        Analyse even if the static check fails (its reasons become warnings).
    progress : callable, optional
        Called as ``progress(done, total)`` after each estimator.
    sensors : tuple of str
        The sensors analysed ("gyro", "accel"): the result holds their axes only, and the static check judges them
        alone (a gyro-only unit whose driver fills the accelerometer with zeros is analysed with ``("gyro",)``).
    origin_s : float
        Where ``imu``'s first sample lies in the recording [s] (a span's start): the still stretch a refusal offers is
        given from the recording's first sample, as ``span`` (``--span``) reads it.

    Raises
    ------
    InputError
        Too few samples, NaN/inf, non-increasing stamps; :class:`NotStaticError` for clearly moving data.
    """
    n = len(imu)
    if n < MIN_SAMPLES:
        raise InputError(
            f"{imu.topic or 'input'}: only {n} IMU samples; need at least {MIN_SAMPLES} for an Allan analysis"
        )
    finite = np.isfinite(imu.t).all() and np.isfinite(imu.gyro).all() and np.isfinite(imu.accel).all()
    if not finite:
        raise InputError(f"{imu.topic or 'input'}: NaN/inf in the IMU samples or stamps; repair or drop them first")
    unknown = [s for s in sensors if s not in ("gyro", "accel")]
    if unknown or not sensors:
        raise ValueError(f"sensors must be among 'gyro', 'accel', got {sensors!r}")
    blocks = [(sensor, block, names) for sensor, block, names in (("gyro", imu.gyro, GYRO_AXES),
                                                                  ("accel", imu.accel, ACCEL_AXES))
              if sensor in sensors]
    for sensor, block, names in blocks:
        for name, column in zip(names, block.T, strict=True):
            if np.ptp(column) == 0:
                others = [s for s in ("gyro", "accel") if s != sensor]
                raise InputError(
                    f"{imu.topic or 'input'}: {name} is constant ({column[0]:g}) over all {n} samples: the driver "
                    "does not publish this axis or the sensor is saturated; no noise can be identified from it. "
                    f"To analyse the {others[0]} alone: --axis {others[0]}"
                )
    axes = tuple(a for _, _, names in blocks for a in names)
    period = imu.sample_period()
    dt = period.require()
    timing, missing = _timing_warnings(imu, period)
    warnings = list(imu.notes) + timing
    check = static_check(imu, dt, axes=axes)
    if check.flags and not allow_motion:
        raise NotStaticError(check.refusal(imu.topic, needs="A static analysis needs the IMU at rest", verb="analyse",
                                           origin_s=origin_s))
    warnings += [f"not static: {m}" for m in check.flags] + check.notes
    wanted = ["allan", *[k for k in kinds if k != "allan"]]
    # Gyro and accel separately: no (N, 6) copy of the samples (peak memory, see docs/analysis.md).
    variances = {}
    for step, kind in enumerate(wanted):
        variances[kind] = stack_axes([allan_family(block, dt, kind, per_decade=per_decade, confidence=confidence)
                                      for _, block, _ in blocks])
        if progress is not None:
            progress(step + 1, len(wanted))
    duration = n * dt
    slopes = {}
    for j, name in enumerate(axes):
        slopes[name] = fit_axis_slopes(variances["allan"], j)
        warnings += _slope_warnings(name, slopes[name], duration)
    return StaticAnalysis(
        axes=axes, n=n, dt=dt, duration_s=duration, topic=imu.topic, variances=variances, slopes=slopes,
        warnings=warnings, period=period, missing=missing,
    )

