"""``imu.yaml``: the analysis's :class:`~imu_noise_id.pipelines.analyze.numbers.PastedNumbers` in Kalibr's keys
and per-axis lists (SI units, stated in its header), and parsed back into them (:func:`parse_imu_yaml`)."""

from __future__ import annotations

import math
from pathlib import Path

import yaml

from ..core.axes import SENSORS
from ..core.constants import CONFIDENCE_95
from ..core.errors import InputError
from ..pipelines.analyze.numbers import (
    KALIBR_COMBINE,
    KALIBR_PREFIX,
    PARAMETERS,
    AxisNumbers,
    ModelReadings,
    OverboundAxis,
    OverboundNumbers,
    PastedNumbers,
    Reading,
    SensorNumbers,
)
from ..pipelines.analyze.static import StaticAnalysis
from .numbers import num


def _pair(ci: tuple[float, float]) -> list[float]:
    return [num(ci[0]), num(ci[1])]


def _kalibr_keys(numbers: PastedNumbers) -> dict:
    """The four Kalibr keys (accelerometer first, as Kalibr's own file lists them)."""
    doc: dict = {}
    for sensor in ("accel", "gyro"):
        if sensor in numbers.sensors:
            s = numbers.sensors[sensor]
            doc[f"{s.prefix}_noise_density"] = num(s.noise_density)
            doc[f"{s.prefix}_random_walk"] = num(s.random_walk)
    return doc


def _sensor_keys(s: SensorNumbers) -> dict:
    """A sensor's per-axis keys: values, intervals, methods (and with final models sources, the Allan-slope readings
    beside them, the per-sample σ, the bias instability and the model names)."""
    doc: dict = {}
    for parameter in PARAMETERS:
        key = f"{s.prefix}_{parameter}"
        readings = [a.reading(parameter) for a in s.axes]
        if s.from_models:
            allan = [a.allan_reading(parameter) for a in s.axes]
            doc[f"{key}_allan_xyz"] = [num(r.value) for r in allan]
            doc[f"{key}_allan_ci_xyz"] = [_pair(r.ci95) for r in allan]
            doc[f"{key}_allan_method_xyz"] = [r.method for r in allan]
            doc[f"{key}_allan_agrees_xyz"] = [parameter not in a.allan_disagreements() for a in s.axes]
            doc[f"{key}_allan"] = num(getattr(s, f"allan_{parameter}"))
        doc[f"{key}_xyz"] = [num(r.value) for r in readings]
        doc[f"{key}_ci_xyz"] = [_pair(r.ci95) for r in readings]
        doc[f"{key}_method_xyz"] = [r.method for r in readings]
        if s.from_models or any(r.source for r in readings):
            doc[f"{key}_source_xyz"] = [r.source for r in readings]
    if not s.from_models:
        return doc
    models = [a.model for a in s.axes]
    doc[f"{s.prefix}_noise_stddev_per_sample_xyz"] = [num(m.noise_stddev_per_sample) for m in models]
    key = f"{s.prefix}_bias_instability"
    doc[f"{key}_xyz"] = [num(m.bias_instability.value) for m in models]
    doc[f"{key}_ci_xyz"] = [_pair(m.bias_instability.ci95) for m in models]
    doc[f"{key}_method_xyz"] = [m.bias_instability.method() for m in models]
    doc[f"{key}_tau_xyz"] = [num(m.bias_instability.tau_at_minimum) for m in models]
    doc[f"{key}_allan_xyz"] = [num(m.bias_instability_allan.value) for m in models]
    doc[f"{key}_allan_method_xyz"] = [m.bias_instability_allan.method("allan") for m in models]
    doc[f"{s.prefix}_final_model_xyz"] = [m.name for m in models]
    return doc


def overbound_dict(ob: OverboundNumbers) -> dict:
    """The ``overbound:`` section: per sensor the Kalibr numbers (max over axes), per axis the values, the τ range,
    the binding τ and the inflation factors over imu.yaml's per-axis values."""
    out: dict = {"horizon_s": num(ob.horizon_s), "tau_range_s": [num(ob.tau_range_s[0]), num(ob.tau_range_s[1])],
                 "covers": ob.covers}
    for sensor, (n, k) in ob.sensors.items():
        prefix = KALIBR_PREFIX[sensor]
        axes = [a for s, axes in SENSORS if s == sensor for a in axes]
        out[f"{prefix}_noise_density"] = num(n)
        out[f"{prefix}_noise_density_xyz"] = [num(ob.axes[a].noise_density) for a in axes]
        out[f"{prefix}_random_walk"] = num(k)
        out[f"{prefix}_random_walk_xyz"] = [num(ob.axes[a].random_walk) for a in axes]
    out["inflation_summary"] = ob.inflation_summary
    out["axes"] = {axis: {"noise_density": num(o.noise_density), "random_walk": num(o.random_walk),
                          "inflation_noise_density": num(o.inflation_noise_density),
                          "inflation_random_walk": num(o.inflation_random_walk),
                          "tau_range_s": [num(o.tau_range_s[0]), num(o.tau_range_s[1])],
                          "binding_tau_s": [num(t) for t in o.binding_tau_s],
                          "at_fitted_value": {"noise_density": o.at_fitted_value[0],
                                              "random_walk": o.at_fitted_value[1]},
                          "inflated_over": o.inflated_over, "covers": o.covers}
                   for axis, o in ob.axes.items()}
    return out


def header(result: StaticAnalysis, with_models: bool) -> list[str]:
    """The comment lines at the top of ``imu.yaml`` (units, conventions, data)."""
    conf = result.allan.confidence
    allan = "*_allan_xyz keys" if with_models else "*_xyz keys (the Kalibr numbers' source)"
    origin = "the fitted noise models" if with_models else "the Allan variance"
    lines = [
        f"# IMU noise parameters for Kalibr / VIO, from {origin} (imu-noise-id analyze).",
        "# Units: *_noise_density: gyroscope rad/s/sqrt(Hz), accelerometer m/s^2/sqrt(Hz) (continuous-time);",
        "#        *_random_walk: gyroscope rad/s^2/sqrt(Hz), accelerometer m/s^3/sqrt(Hz); update_rate Hz.",
        f"# The four Kalibr numbers are the {KALIBR_COMBINE} over the sensor's x, y, z axes; per-axis values are in",
        f"# the *_xyz keys, their {100 * conf:g} % confidence intervals in *_ci_xyz. Allan-slope readings ({allan}):",
        "# white noise is the -1/2 slope line read at tau = 1 s, random walk the +1/2 slope line at tau = 3 s;",
        "# method upper_bound = slope not reached in this record. Where the shortest tau show the sensor's own",
        "# low-pass (the AV falls slower than 1/tau, then steepens to it) the lines are read beyond that roll-off.",
        f"# Data: {result.n} samples, {result.duration_s:.1f} s at {result.rate_hz:.6g} Hz from {result.topic or '?'}.",
    ]
    if result.period is not None and not result.period.trusted:
        lines += [f"# WARNING (update_rate): {w}" for w in result.period.warnings]
    if with_models:
        lines += [
            "# With models (default): the Kalibr keys and *_xyz / *_ci_xyz come from each axis's FINAL model",
            "# (model.yaml: the closed loop's last step, or the model selection), with its 95 % intervals:",
            "# noise density = passband white noise sqrt(N_WN^2 + N_LPF^2 + N_DLPF^2 + N_MA^2 + N_OSC^2), each at",
            "# its zero-frequency density as sampled (what the Allan variance shows as N^2/tau; an LPF near Nyquist",
            "# aliases above its continuous N), N_OSC that of an OSC of short memory (5 samples or 50 ms),",
            "# random walk = RW; narrow oscillations (OSC), sinusoids, GMs, flicker noise (BI), the shape of the",
            "# sensor's own filter (LPF, DLPF, MA, broad OSC) and temperature are kept OUT of them (see model.yaml).",
            "# *_method_xyz: model; or bound: the record does not identify the walk (K's 95 % interval reaches zero,",
            "# or the final model has no random walk and the value is the largest walk the long-tau Allan variance",
            "# supports): the upper end, interval [0, value]; allan_slope / allan_upper_bound only where neither",
            "# exists or the axis was not analysed with a model (*_source_xyz says which); or unresolved: the final",
            "# model is not trusted",
            "# (the closed loop's verdict failed, or its N disagrees with the data's passband level; *_source_xyz",
            "# says which): the value is the axis's overbound (an upper bound, below), its interval [0, value].",
            "# The Allan-slope readings are in *_allan_xyz and *_allan; *_allan_agrees_xyz is false where a reading's",
            "# 95 % interval and the pasted number's share no value (the slope line takes the AV over its tau range as",
            "# white noise and a walk alone, the final model is fitted to the whole record; the console says which).",
            "# *_noise_stddev_per_sample_xyz: per-sample std of the high-frequency noise at update_rate, in u: use it",
            "# (squared) as the Imu message covariance; it is below noise_density*sqrt(update_rate) where the",
            "# sensor's own low-pass cuts below the Nyquist frequency.",
            "# *_bias_instability_xyz [rad/s or m/s^2]: min of the final model's Allan deviation (vibration lines left",
            "# out) / 0.664 (IEEE 952), at *_tau_xyz, with a 95 % interval from the fit's parameter uncertainty;",
            "# method model_upper_bound: the deviation still falls at a tenth of the record (not reached): the value",
            "# is the 95 % upper end of that reading, its interval [0, value].",
            "# *_bias_instability_allan_xyz: the same reading off the data's Allan deviation (no interval).",
        ]
    lines += [
        "# overbound: the honest version of 'inflate the noise x10': for the tau range a filter cares about",
        "# (tau_range_s: the sampling period to --horizon), the smallest WN+RW (Kalibr form, same units) whose Allan",
        "# variance lies above the data's upper confidence bound (and the final model's AV) at every tau of the",
        "# range, and not below the values above; 'smallest' = least mean ratio AV_overbound/bound over the tau grid.",
        "# Per axis with its inflation factors over the values above and the tau where it touches the bound",
        "# (binding_tau_s). imu-noise-id export --overbound writes the filters' files from it.",
    ]
    return lines


def imu_doc(numbers: PastedNumbers) -> dict:
    """The content of ``imu.yaml`` (module docstring) from the analysis's numbers, with its ``overbound:`` section
    when they have one."""
    doc = _kalibr_keys(numbers)
    doc["update_rate"] = num(numbers.rate_hz)
    if numbers.rate_source is not None:
        doc["update_rate_source"] = numbers.rate_source
        doc["update_rate_trusted"] = numbers.rate_trusted
    doc["rostopic"] = numbers.topic
    doc["confidence_level"] = numbers.confidence
    for s in numbers.sensors.values():
        doc |= _sensor_keys(s)
    if numbers.overbound is not None:
        doc["overbound"] = overbound_dict(numbers.overbound)
    return doc


def write_imu_yaml(path: Path, result: StaticAnalysis, doc: dict, with_models: bool) -> Path:
    """Write ``imu.yaml``: the header and ``doc`` (:func:`imu_doc`)."""
    text = "\n".join(header(result, with_models)) + "\n"
    path.write_text(text + yaml.safe_dump(doc, sort_keys=False, default_flow_style=None))
    return path


def _number(doc: dict, key: str, where: str) -> float:
    value = doc.get(key)
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(f"{where} lacks {key} (a number): rerun imu-noise-id analyze")
    return float(value)


def _listed(doc: dict, key: str) -> list | None:
    value = doc.get(key)
    return value if isinstance(value, list) and len(value) == 3 else None


def _axes_of(doc: dict, sensor: str, prefix: str) -> tuple[AxisNumbers, ...]:
    """The per-axis readings of a sensor where imu.yaml lists its values (a hand-written file may give the Kalibr
    keys alone); intervals, methods and sources where listed (else NaN, ``""``, None)."""
    lists = {}
    for parameter in PARAMETERS:
        key = f"{prefix}_{parameter}"
        values = _listed(doc, f"{key}_xyz")
        if values is None:
            return ()
        cis = _listed(doc, f"{key}_ci_xyz") or [[math.nan, math.nan]] * 3
        methods = _listed(doc, f"{key}_method_xyz") or [""] * 3
        sources = _listed(doc, f"{key}_source_xyz") or [None] * 3
        lists[parameter] = [Reading(float(v), (float(c[0]), float(c[1])), str(m), s)
                            for v, c, m, s in zip(values, cis, methods, sources, strict=True)]
    per_sample = _listed(doc, f"{prefix}_noise_stddev_per_sample_xyz")
    names = _listed(doc, f"{prefix}_final_model_xyz") or [""] * 3
    out = []
    for i, axis in enumerate(dict(SENSORS)[sensor]):
        model = None if per_sample is None else ModelReadings(str(names[i]), float(per_sample[i]))
        out.append(AxisNumbers(axis, lists["noise_density"][i], lists["random_walk"][i], model=model))
    return tuple(out)


def _overbound_of(doc: dict) -> OverboundNumbers | None:
    ob = doc.get("overbound")
    if not isinstance(ob, dict):
        return None
    sensors, axes = {}, {}
    for sensor, prefix in KALIBR_PREFIX.items():
        n, k = ob.get(f"{prefix}_noise_density"), ob.get(f"{prefix}_random_walk")
        if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in (n, k)):
            return None
        sensors[sensor] = (float(n), float(k))
        n_xyz, k_xyz = ob.get(f"{prefix}_noise_density_xyz"), ob.get(f"{prefix}_random_walk_xyz")
        if isinstance(n_xyz, list) and isinstance(k_xyz, list):
            for axis, n_a, k_a in zip(dict(SENSORS)[sensor], n_xyz, k_xyz, strict=False):
                axes[axis] = OverboundAxis(float(n_a), float(k_a), math.nan, math.nan, (math.nan, math.nan))
    lo, hi = ob.get("tau_range_s", [math.nan, math.nan])
    return OverboundNumbers(sensors, float(ob.get("horizon_s", math.nan)), (float(lo), float(hi)),
                            str(ob.get("covers", "")), str(ob.get("inflation_summary", "")), axes)


def parse_imu_yaml(doc: dict, where: str = "imu.yaml") -> PastedNumbers:
    """The numbers of an ``imu.yaml`` (as :func:`imu_doc` writes it, or hand-written with the four Kalibr keys and
    ``update_rate`` alone). Raises InputError naming ``where`` and the missing key."""
    rate = _number(doc, "update_rate", where)
    held = [prefix for prefix in KALIBR_PREFIX.values() if f"{prefix}_noise_density" in doc]
    if len(held) == 1:
        raise InputError(f"{where} holds the {held[0]}'s numbers alone (an analysis of one sensor, --axis): the "
                         "filters' files need both sensors' numbers; analyse both to export them")
    sensors = {}
    for sensor, prefix in KALIBR_PREFIX.items():
        n = _number(doc, f"{prefix}_noise_density", where)
        k = _number(doc, f"{prefix}_random_walk", where)
        axes = _axes_of(doc, sensor, prefix)
        sensors[sensor] = SensorNumbers(sensor, n, k, axes, bool(axes) and f"{prefix}_source_xyz" in doc)
    confidence = doc.get("confidence_level", CONFIDENCE_95)
    topic = doc.get("rostopic")
    return PastedNumbers(rate, None if topic is None else str(topic), {s: sensors[s] for s in ("gyro", "accel")},
                         float(confidence) if isinstance(confidence, int | float) else CONFIDENCE_95,
                         overbound=_overbound_of(doc))
