"""The numbers users paste, built once from an analysis (:func:`pasted_numbers`) and only rendered afterwards:
``imu.yaml``, every export, the console, the report and the fleet table read a :class:`PastedNumbers`.

Per sensor and axis: the white-noise density N [u/√Hz] and the random walk K [u/s/√Hz] with their 95 % intervals,
methods and sources (the final model's where every axis of the sensor has one, else the Allan slopes'), the Allan-slope
readings beside them, the per-sample standard deviation [u], the bias instability B [u]; per sensor Kalibr's one number
(the maximum over the axes); the rate, topic and the WN+RW overbound. Rules (which reading stands in where a model has
no random walk, why the maximum): docs/analysis.md, "The numbers to paste".
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from ...core.axes import SENSORS, sensor_of
from ...core.errors import InputError

if TYPE_CHECKING:
    from ...core.estimation.readouts.instability import BiasInstability
    from .final import FinalModel
    from .overbound import AxisOverbound
    from .static import StaticAnalysis

#: How the one number per sensor that Kalibr wants is made from its axes.
KALIBR_COMBINE = "max"
#: The Kalibr key prefix of each sensor.
KALIBR_PREFIX = {"gyro": "gyroscope", "accel": "accelerometer"}
#: The two numbers of an axis, as :class:`AxisNumbers` names them.
PARAMETERS = ("noise_density", "random_walk")
#: The methods of a number that is an Allan slope's reading (its own, or standing in for a model without it).
ALLAN_METHODS = ("fit", "upper_bound", "allan_slope", "allan_upper_bound")
#: The methods whose value is an upper bound, its interval (0, value): a K or N the record does not resolve, and a
#: bias instability whose Allan minimum lies beyond the τ read (``BiasInstability.method``).
UPPER_BOUND_METHODS = ("bound", "unresolved", "allan_upper_bound", "upper_bound", "model_upper_bound")


@dataclass(frozen=True)
class Reading:
    """One number of one axis [SI] with its 95 % interval (lo, hi), how it was obtained and from what.

    ``method``: a final model's ``model``, ``bound`` or ``unresolved`` (:class:`~...readouts.kalibr.KalibrValue`);
    ``allan_slope`` / ``allan_upper_bound`` where the Allan-slope reading stands in for a model without the component;
    an Allan slope's own ``fit`` / ``upper_bound``; ``overbound``. ``source``: in words, None where not stated.
    """

    value: float
    ci95: tuple[float, float]
    method: str
    source: str | None = None

    def disjoint_from(self, other: Reading) -> bool:
        """Whether this reading's 95 % interval and ``other``'s share no value (False where an end is not finite)."""
        (lo, hi), (other_lo, other_hi) = self.ci95, other.ci95
        if not all(math.isfinite(v) for v in (lo, hi, other_lo, other_hi)):
            return False
        return hi < other_lo or other_hi < lo


@dataclass(frozen=True)
class ModelReadings:
    """What an axis's final model adds: its name, the per-sample standard deviation of its high-frequency noise at the
    record's rate [u] and the bias instability read off the model and off the data's AV (None when parsed from a file
    that does not hold them)."""

    name: str
    noise_stddev_per_sample: float
    bias_instability: BiasInstability | None = None
    bias_instability_allan: BiasInstability | None = None


@dataclass(frozen=True)
class AxisNumbers:
    """One axis: the N and K to paste, the Allan-slope readings beside them, the final model's readings (None when the
    sensor's numbers come from the Allan slopes)."""

    axis: str
    noise_density: Reading
    random_walk: Reading
    allan_noise_density: Reading | None = None
    allan_random_walk: Reading | None = None
    model: ModelReadings | None = None

    def reading(self, parameter: str) -> Reading:
        """``noise_density`` or ``random_walk``."""
        return getattr(self, parameter)

    def allan_reading(self, parameter: str) -> Reading | None:
        """The Allan-slope reading of ``noise_density`` or ``random_walk`` beside the pasted one (None without)."""
        return getattr(self, f"allan_{parameter}")

    def allan_disagreements(self) -> tuple[str, ...]:
        """The parameters (of :data:`PARAMETERS`) whose Allan-slope reading and pasted number (a model's value, a
        bound, or an unresolved axis's overbound; not the slope's own) have 95 % intervals that share no value
        (:meth:`Reading.disjoint_from`): the slope line takes the AV over its τ range as white noise and a walk alone,
        the final model is fitted to the whole record, and the two then read the record differently (a walk read
        through a GM's bump, docs/analysis.md, "The numbers to paste")."""
        return tuple(p for p in PARAMETERS
                     if (allan := self.allan_reading(p)) is not None and self.reading(p).method not in ALLAN_METHODS
                     and allan.disjoint_from(self.reading(p)))


@dataclass(frozen=True)
class SensorNumbers:
    """One sensor (``gyro`` or ``accel``): Kalibr's N [u/√Hz] and K [u/s/√Hz] (:data:`KALIBR_COMBINE` over its axes),
    the axes (empty when only the Kalibr numbers are known), whether they come from final models, and the Allan-slope
    Kalibr numbers beside them (None when they are the Kalibr numbers)."""

    sensor: str
    noise_density: float
    random_walk: float
    axes: tuple[AxisNumbers, ...] = ()
    from_models: bool = False
    allan_noise_density: float | None = None
    allan_random_walk: float | None = None

    @property
    def prefix(self) -> str:
        """``gyroscope`` or ``accelerometer``: the Kalibr keys' prefix."""
        return KALIBR_PREFIX[self.sensor]

    def noise_stddev_per_sample(self, rate_hz: float) -> float:
        """The largest per-sample standard deviation over the axes [u] (the final models' high-frequency noise at
        ``rate_hz``), or N·√rate without final models (white noise sampled at the rate)."""
        models = [a.model for a in self.axes]
        if models and all(m is not None for m in models):
            return max(m.noise_stddev_per_sample for m in models)
        return self.noise_density * math.sqrt(rate_hz)


@dataclass(frozen=True)
class OverboundAxis:
    """The WN+RW overbound of one axis: N, K, the factors over the pasted values, the τ [s] covered, the τ where it
    touches the bound, whether N and K sit on the pasted values, what the factors are relative to and what it covers."""

    noise_density: float
    random_walk: float
    inflation_noise_density: float
    inflation_random_walk: float
    tau_range_s: tuple[float, float]
    binding_tau_s: tuple[float, ...] = ()
    at_fitted_value: tuple[bool, bool] = (False, False)
    inflated_over: str = ""
    covers: str = ""

    @classmethod
    def of(cls, o: AxisOverbound) -> OverboundAxis:
        """From the pipeline's overbound of one axis."""
        return cls(o.noise_density, o.random_walk, o.inflation_noise_density, o.inflation_random_walk, o.tau_range,
                   tuple(o.bound.binding_tau), (bool(o.bound.at_floor[0]), bool(o.bound.at_floor[1])),
                   o.reference_source, o.covers)


@dataclass(frozen=True)
class OverboundNumbers:
    """The overbound of every axis, per sensor its Kalibr numbers (max over axes), the horizon [s], the τ range [s],
    what it covers and the inflation factors in words."""

    sensors: dict[str, tuple[float, float]]
    horizon_s: float
    tau_range_s: tuple[float, float]
    covers: str
    inflation_summary: str = ""
    axes: dict[str, OverboundAxis] = field(default_factory=dict)


@dataclass(frozen=True)
class PastedNumbers:
    """Everything a filter's configuration takes from an analysis (module docstring): the sensors' numbers, the rate
    [Hz] (with how it was found and whether it is trusted), the topic, the confidence level of the intervals, the
    overbound, and ``values_of``: what the values are when they are not the analysis's own (the overbound's)."""

    rate_hz: float
    topic: str | None
    sensors: dict[str, SensorNumbers]
    confidence: float
    rate_source: str | None = None
    rate_trusted: bool | None = None
    overbound: OverboundNumbers | None = None
    values_of: str | None = None

    def sensor(self, name: str) -> SensorNumbers:
        """The sensor ``gyro`` or ``accel``; InputError when the analysis has no numbers for it."""
        if name not in self.sensors:
            raise InputError(f"no {KALIBR_PREFIX.get(name, name)} numbers in this analysis")
        return self.sensors[name]

    def axis(self, axis: str) -> AxisNumbers | None:
        """The numbers of ``axis`` (None when only the sensor's are known)."""
        sensor = self.sensors.get(sensor_of(axis))
        return next((a for a in sensor.axes if a.axis == axis), None) if sensor else None

    def overbound_values(self) -> PastedNumbers:
        """These numbers with N and K replaced by the overbound's (method ``overbound``, interval (0, value)), no
        model readings (a WN+RW has no low-pass) and ``values_of`` saying what they are; InputError without an
        overbound."""
        ob = self.overbound
        if ob is None or not all(s in ob.sensors for s in self.sensors):
            raise InputError("imu.yaml has no 'overbound:' section with the four Kalibr numbers: rerun imu-noise-id "
                             "analyze (it writes one) to export the overbound")
        sensors = {}
        for name, s in self.sensors.items():
            axes = tuple(AxisNumbers(a.axis, _bound(ob.axes[a.axis].noise_density),
                                     _bound(ob.axes[a.axis].random_walk)) for a in s.axes if a.axis in ob.axes)
            sensors[name] = SensorNumbers(name, *ob.sensors[name], axes=axes)
        lo, hi = ob.tau_range_s
        values_of = (f"the smallest WN+RW whose Allan variance lies above the data's upper {100 * self.confidence:g} % "
                     f"bound and the final model's AV at every tau in [{lo:g}, {hi:g}] s, not below the fitted values; "
                     f"inflation over them: {ob.inflation_summary or 'see imu.yaml'}")
        return replace(self, sensors=sensors, values_of=values_of)


def _bound(value: float) -> Reading:
    return Reading(value, (0.0, value), "overbound")


def _allan(static: StaticAnalysis, axis: str, parameter: str) -> Reading:
    c = getattr(static.slopes[axis], parameter)
    return Reading(c.value, (c.ci[0], c.ci[1]), c.method)


def _allan_in_words(static: StaticAnalysis, axis: str, parameter: str) -> str:
    """The Allan-slope reading standing in for a model value, in words, with the τ range it was read over."""
    c = getattr(static.slopes[axis], parameter)
    what = ("the Allan variance's upper bound (its slope line not reached in this record)" if c.method == "upper_bound"
            else "the Allan-slope reading (its slope line)")
    lo, hi = c.tau_range
    return f"{what}, read over tau {lo:.3g}–{hi:.3g} s"


def _allan_standing_in(static: StaticAnalysis, axis: str, parameter: str, why: str) -> Reading:
    """The Allan-slope reading standing in for a model value, as ``allan_slope`` / ``allan_upper_bound``, its source
    ``why`` and the τ range it was read over."""
    allan = _allan(static, axis, parameter)
    method = "allan_upper_bound" if allan.method == "upper_bound" else "allan_slope"
    return Reading(allan.value, allan.ci95, method, f"{why}; given instead: {_allan_in_words(static, axis, parameter)}")


def _from_model(static: StaticAnalysis, axis: str, final: FinalModel, parameter: str) -> Reading:
    """The final model's value, or where the model has none (not identifiable) the Allan-slope reading, marked."""
    v = getattr(final, parameter)
    if v.value is not None:
        return Reading(v.value, (v.ci95[0], v.ci95[1]), v.method, v.source)
    return _allan_standing_in(static, axis, parameter, v.source)


def axis_readings(static: StaticAnalysis, axis: str, final: FinalModel | None) -> tuple[Reading, Reading]:
    """N and K of one axis: its final model's (the Allan-slope reading where the model has no value), else the Allan
    slopes'."""
    if final is None:
        return _allan(static, axis, "noise_density"), _allan(static, axis, "random_walk")
    return (_from_model(static, axis, final, "noise_density"), _from_model(static, axis, final, "random_walk"))


def _axis(static: StaticAnalysis, axis: str, final: FinalModel | None) -> AxisNumbers:
    n, k = axis_readings(static, axis, final)
    if final is None:
        return AxisNumbers(axis, n, k)
    model = ModelReadings(final.model, final.noise_stddev_per_sample, final.bias_instability,
                          final.bias_instability_allan)
    return AxisNumbers(axis, n, k, _allan(static, axis, "noise_density"), _allan(static, axis, "random_walk"), model)


#: Why an axis of a partly modelled sensor gives its Allan-slope readings.
NOT_MODELLED = "this axis was not analysed with a model (not among the analysed axes)"


def _partly_modelled(static: StaticAnalysis, axis: str, final: FinalModel | None) -> AxisNumbers:
    """One axis of a sensor only some of whose axes have final models: the model's N and K where it has one (an
    Allan slope never replaces a likelihood reading), else the Allan slopes', marked (:func:`_allan_standing_in`)."""
    if final is not None:
        return AxisNumbers(axis, *axis_readings(static, axis, final))
    return AxisNumbers(axis, *(_allan_standing_in(static, axis, p, NOT_MODELLED)
                               for p in PARAMETERS))


def _sensor(static: StaticAnalysis, sensor: str, axes: tuple[str, ...], finals: dict[str, FinalModel]) -> SensorNumbers:
    from_models = all(a in finals for a in axes)
    if from_models or not any(a in finals for a in axes):
        numbers = tuple(_axis(static, a, finals.get(a)) for a in axes)
    else:
        numbers = tuple(_partly_modelled(static, a, finals.get(a)) for a in axes)
    n = _combined([a.noise_density.value for a in numbers])
    k = _combined([a.random_walk.value for a in numbers])
    if not from_models:
        return SensorNumbers(sensor, n, k, numbers)
    return SensorNumbers(sensor, n, k, numbers, True, _combined([a.allan_noise_density.value for a in numbers]),
                         _combined([a.allan_random_walk.value for a in numbers]))


def _combined(values: list[float]) -> float:
    """:data:`KALIBR_COMBINE` of a sensor's axis values (NaN when one is NaN)."""
    return float(np.max(values))


def _factor_range(values: list[float]) -> str:
    lo, hi = min(values), max(values)
    return f"x{lo:.3g}" if f"{lo:.3g}" == f"{hi:.3g}" else f"x{lo:.3g}-{hi:.3g}"


def _overbound(overbounds: dict[str, AxisOverbound]) -> OverboundNumbers | None:
    if not overbounds:
        return None
    first = next(iter(overbounds.values()))
    sensors, summary = {}, []
    for sensor, axes in SENSORS:
        obs = [overbounds[a] for a in axes if a in overbounds]
        if len(obs) != len(axes):
            continue
        sensors[sensor] = (max(o.noise_density for o in obs), max(o.random_walk for o in obs))
        summary.append(f"{sensor} N {_factor_range([o.inflation_noise_density for o in obs])}, "
                       f"K {_factor_range([o.inflation_random_walk for o in obs])}")
    return OverboundNumbers(sensors, first.horizon_s, first.tau_range, first.covers.split(" (")[0], "; ".join(summary),
                            {axis: OverboundAxis.of(o) for axis, o in overbounds.items()})


def pasted_numbers(static: StaticAnalysis, finals: dict[str, FinalModel],
                   overbounds: dict[str, AxisOverbound] | None = None, topic: str | None = None) -> PastedNumbers:
    """The numbers to paste from the Allan stage ``static``, the final models ``finals`` (per axis; a sensor's numbers
    come from them when all its axes have one, each axis's N and K from its own where only some have one) and the
    ``overbounds``; ``topic`` defaults to the recording's."""
    sensors = {sensor: _sensor(static, sensor, axes, finals) for sensor, axes in SENSORS
               if all(a in static.slopes for a in axes)}
    period = static.period
    return PastedNumbers(static.rate_hz, topic if topic is not None else static.topic, sensors,
                         static.allan.confidence, period.describe() if period is not None else None,
                         period.trusted if period is not None else None, _overbound(overbounds or {}))
