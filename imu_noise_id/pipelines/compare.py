"""``compare`` as one pipeline: a static recording at the reference's rate and a reference in, one :class:`Comparison`
out (per axis :func:`~imu_noise_id.core.watch.compare.compare_axis`: noise level by CUSUM, bias step, new line)."""

from __future__ import annotations

from dataclasses import dataclass, field

from ..core.axes import ImuSeries, sensor_of
from ..core.errors import InputError
from ..core.stillness import static_check
from ..core.watch.axis_reference import AxisReference, rate_mismatch
from ..core.watch.compare import AxisComparison, compare_axis
from ..core.watch.noise_level import DEFAULT_FALSE_ALARMS_PER_HOUR, DEFAULT_RATIO, NoiseLevel, beyond_limit, per_test


@dataclass(frozen=True)
class Comparison:
    """Per axis the tests' outcome, and notes (what differs in the inputs without being refused)."""

    axes: dict[str, AxisComparison]
    duration_s: float
    notes: list[str] = field(default_factory=list)

    @property
    def degraded(self) -> list[str]:
        return [axis for axis, c in self.axes.items() if c.degraded]


def compare(imu: ImuSeries, references: dict[str, AxisReference], rate_hz: float, topic: str | None = None, *,
            ratio: float = DEFAULT_RATIO,
            false_alarms_per_hour: float = DEFAULT_FALSE_ALARMS_PER_HOUR,
            limits: dict[str, float] | None = None, other_topic: bool = False) -> Comparison:
    """Test ``imu`` against ``references`` made at ``rate_hz`` [Hz] from ``topic`` and against ``limits``
    (sensor "gyro"/"accel" → noise-density limit [u/√Hz]), at ``false_alarms_per_hour`` for the whole unit (shared
    among its axes and tests, ``noise_level.per_test``); ``other_topic``: a reference made from another topic (another
    IMU, e.g. the fleet's typical unit) is taken, with a note. InputError for another rate than the reference's,
    another topic (without ``other_topic``), a recording that is not static or one too short for the tests."""
    period = imu.sample_period()
    if period.refusal is not None:
        raise InputError(f"compare: {period.refusal}")
    dt = period.value
    mismatch = rate_mismatch(1.0 / dt, rate_hz, "")
    if mismatch is not None:
        raise InputError(f"compare: {mismatch}")
    check = static_check(imu, dt)
    if check.flags:
        raise InputError("compare: the recording does not look static (" + "; ".join(check.flags) + "): give the "
                         "still part with --span START:END")
    notes = list(imu.notes)  # the reader's repairs and a span, as analyze's warnings give them
    if topic and imu.topic and topic != imu.topic:
        if not other_topic:
            raise InputError(f"compare: the reference was made from {topic}, this recording is {imu.topic}: another "
                             f"IMU's (pass --topic {topic} if the bag has it, or --other-topic to compare against "
                             "another unit, e.g. the fleet's typical one)")
        notes.append(f"the reference was made from {topic}, this recording is {imu.topic} (--other-topic)")
    axes = {}
    each = per_test(false_alarms_per_hour, len(references))
    for axis, ref in references.items():
        try:
            axes[axis] = compare_axis(imu.axis(axis), dt, ref, ratio=ratio, false_alarms_per_hour=each,
                                      limit=(limits or {}).get(sensor_of(axis)))
        except ValueError as exc:
            raise InputError(f"compare: {axis}: {exc}") from None
    return Comparison(axes, float(imu.t[-1] - imu.t[0]), notes)


def beyond_spec(imu: ImuSeries, dt: float, own: dict[str, AxisReference], limits: dict[str, float], *,
                false_alarms_per_hour: float = DEFAULT_FALSE_ALARMS_PER_HOUR) -> dict[str, NoiseLevel]:
    """``compare --spec`` (``batch --spec``), a unit without a reference: per axis of ``imu`` at period ``dt`` [s] whose
    sensor has a noise-density limit in ``limits`` [u/√Hz], the upward CUSUM against it (``noise_level.beyond_limit``)
    with the shape of the axis's own analysis ``own[axis]`` (N and final model; white noise without components) scaled
    to the limit, at ``false_alarms_per_hour`` for the unit (``per_test``); ``sustained``: beyond the limit."""
    each = per_test(false_alarms_per_hour, len(own))
    return {axis: beyond_limit(imu.axis(axis), dt, reference.difference_variance_at(limits[sensor_of(axis)], dt),
                               false_alarms_per_hour=each)
            for axis, reference in own.items() if sensor_of(axis) in limits}
