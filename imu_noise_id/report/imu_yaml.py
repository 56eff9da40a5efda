"""``imu.yaml``: the numbers users paste into Kalibr-style configs (SI units, stated in its header), written once
from an analysis result. The Kalibr keys are the max over the sensor's axes: the final models' values
(:func:`add_final_values`) with a model stage, else the Allan slopes'.
"""

from __future__ import annotations

from pathlib import Path

import yaml

from ..core.axes import SENSORS, sensor_of
from ..pipelines.analyze.final import FinalModel
from ..pipelines.analyze.overbound import AxisOverbound
from ..pipelines.analyze.static import StaticAnalysis, kalibr_parameters
from .numbers import num

#: How the one number per sensor that Kalibr wants is made from the three axes.
KALIBR_COMBINE = "max"
_PREFIX = {"gyro": "gyroscope", "accel": "accelerometer"}


def axis_key(axis: str, parameter: str) -> str:
    """The imu.yaml key of ``parameter`` for ``axis``'s sensor, e.g. ``gyroscope_noise_density`` for gyro_z (its
    per-axis lists add ``_xyz``)."""
    return f"{_PREFIX[sensor_of(axis)]}_{parameter}"


def kalibr_dict(result: StaticAnalysis, rostopic: str) -> dict:
    """Kalibr ``imu.yaml`` content from the Allan slopes: its six keys plus per-axis values, CIs and methods."""
    doc: dict = {k: num(v) for k, v in kalibr_parameters(result, KALIBR_COMBINE).items()}
    doc["update_rate"] = num(result.rate_hz)
    if result.period is not None:
        doc["update_rate_source"] = result.period.describe()
        doc["update_rate_trusted"] = result.period.trusted
    doc["rostopic"] = rostopic
    doc["confidence_level"] = result.allan.confidence
    for sensor, axes in SENSORS:
        for parameter in ("noise_density", "random_walk"):
            key = f"{_PREFIX[sensor]}_{parameter}"
            comps = [getattr(result.slopes[a], parameter) for a in axes]
            doc[f"{key}_xyz"] = [num(c.value) for c in comps]
            doc[f"{key}_ci_xyz"] = [[num(c.ci[0]), num(c.ci[1])] for c in comps]
            doc[f"{key}_method_xyz"] = [c.method for c in comps]
    return doc


def add_final_values(doc: dict, finals: dict[str, FinalModel], result: StaticAnalysis | None = None) -> None:
    """Put the final models' numbers into the Kalibr keys and their per-axis lists, in place.

    Per sensor with a final model on all three axes: ``<key>_xyz``, ``<key>_ci_xyz``, ``<key>_method_xyz`` (``model``,
    ``allan_slope``/``allan_upper_bound`` for a missing random walk, ``unresolved``: the overbound's value and
    (0, value)); the Kalibr key their max; the Allan-slope values moved to ``<key>_allan[_ci|_method]_xyz`` and
    ``<key>_allan``; ``<prefix>_noise_stddev_per_sample_xyz``; with ``result``, ``<key>_source_xyz`` where the
    Allan-slope reading stands in, with its τ range.
    """
    for sensor, axes in SENSORS:
        if not all(a in finals for a in axes):
            continue
        for parameter in ("noise_density", "random_walk"):
            key = f"{_PREFIX[sensor]}_{parameter}"
            for suffix in ("", "_ci", "_method"):
                doc[f"{key}_allan{suffix}_xyz"] = doc.pop(f"{key}{suffix}_xyz")
            doc[f"{key}_allan"] = doc[key]
            values, cis, methods, sources = [], [], [], []
            for i, axis in enumerate(axes):
                v = getattr(finals[axis], parameter)
                if v.value is not None:
                    values.append(v.value)
                    cis.append([num(v.ci95[0]), num(v.ci95[1])])
                    methods.append(v.method)
                    sources.append(v.source)
                else:  # not identifiable from the record: the Allan-slope reading (a bound when not reached)
                    values.append(doc[f"{key}_allan_xyz"][i])
                    cis.append(list(doc[f"{key}_allan_ci_xyz"][i]))
                    bound = doc[f"{key}_allan_method_xyz"][i] == "upper_bound"
                    methods.append("allan_" + ("upper_bound" if bound else "slope"))
                    sources.append(f"{v.source}; given instead: {_allan_reading(result, axis, parameter, bound)}")
            doc[key] = num(max(values))
            doc[f"{key}_xyz"] = [num(v) for v in values]
            doc[f"{key}_ci_xyz"] = cis
            doc[f"{key}_method_xyz"] = methods
            doc[f"{key}_source_xyz"] = sources
        doc[f"{_PREFIX[sensor]}_noise_stddev_per_sample_xyz"] = [num(finals[a].noise_stddev_per_sample) for a in axes]
        key = f"{_PREFIX[sensor]}_bias_instability"
        model_b = [finals[a].bias_instability for a in axes]
        doc[f"{key}_xyz"] = [num(b.value) for b in model_b]
        doc[f"{key}_ci_xyz"] = [[num(b.ci95[0]), num(b.ci95[1])] for b in model_b]
        doc[f"{key}_method_xyz"] = ["model_minimum" if b.reached else "model_upper_bound" for b in model_b]
        doc[f"{key}_tau_xyz"] = [num(b.tau_at_minimum) for b in model_b]
        allan_b = [finals[a].bias_instability_allan for a in axes]
        doc[f"{key}_allan_xyz"] = [num(b.value) for b in allan_b]
        doc[f"{key}_allan_method_xyz"] = ["allan_minimum" if b.reached else "allan_upper_bound" for b in allan_b]
        doc[f"{_PREFIX[sensor]}_final_model_xyz"] = [finals[a].model for a in axes]


def _allan_reading(result: StaticAnalysis | None, axis: str, parameter: str, bound: bool) -> str:
    """The Allan-slope reading standing in for a model value, in words, with the τ range it was read over."""
    what = ("the Allan variance's upper bound (its slope line not reached in this record)" if bound
            else "the Allan-slope reading (its slope line)")
    if result is None or axis not in result.slopes:
        return what
    lo, hi = getattr(result.slopes[axis], parameter).tau_range
    return f"{what}, read over tau {lo:.3g}–{hi:.3g} s"


def _range(values: list[float]) -> str:
    lo, hi = min(values), max(values)
    return f"x{lo:.3g}" if f"{lo:.3g}" == f"{hi:.3g}" else f"x{lo:.3g}-{hi:.3g}"


def overbound_dict(overbounds: dict[str, AxisOverbound]) -> dict:
    """The ``overbound:`` section: per sensor the Kalibr numbers (max over axes), per axis the values, the τ range,
    the binding τ and the inflation factors over imu.yaml's per-axis values."""
    first = next(iter(overbounds.values()))
    out: dict = {"horizon_s": num(first.horizon_s), "tau_range_s": [num(first.tau_range[0]), num(first.tau_range[1])],
                 "covers": first.covers.split(" (")[0]}
    summary = []
    for sensor, axes in SENSORS:
        obs = [overbounds[a] for a in axes if a in overbounds]
        if len(obs) != len(axes):
            continue
        for parameter in ("noise_density", "random_walk"):
            key = f"{_PREFIX[sensor]}_{parameter}"
            out[key] = num(max(getattr(o, parameter) for o in obs))
            out[f"{key}_xyz"] = [num(getattr(o, parameter)) for o in obs]
        summary.append(f"{sensor} N {_range([o.inflation_noise_density for o in obs])}, "
                       f"K {_range([o.inflation_random_walk for o in obs])}")
    out["inflation_summary"] = "; ".join(summary)
    out["axes"] = {axis: {"noise_density": num(o.noise_density), "random_walk": num(o.random_walk),
                          "inflation_noise_density": num(o.inflation_noise_density),
                          "inflation_random_walk": num(o.inflation_random_walk),
                          "tau_range_s": [num(o.tau_range[0]), num(o.tau_range[1])],
                          "binding_tau_s": [num(t) for t in o.bound.binding_tau],
                          "at_fitted_value": {"noise_density": o.bound.at_floor[0],
                                              "random_walk": o.bound.at_floor[1]},
                          "inflated_over": o.reference_source, "covers": o.covers}
                   for axis, o in overbounds.items()}
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
            "# exists; or unresolved: the final model is not trusted",
            "# (the closed loop's verdict failed, or its N disagrees with the data's passband level; *_source_xyz",
            "# says which): the value is the axis's overbound (an upper bound, below), its interval [0, value].",
            "# The Allan-slope readings are in *_allan_xyz and *_allan.",
            "# *_noise_stddev_per_sample_xyz: per-sample std of the high-frequency noise at update_rate, in u: use it",
            "# (squared) as the Imu message covariance; it is below noise_density*sqrt(update_rate) where the",
            "# sensor's own low-pass cuts below the Nyquist frequency.",
            "# *_bias_instability_xyz [rad/s or m/s^2]: min of the final model's Allan deviation (vibration lines left",
            "# out) / 0.664 (IEEE 952), at *_tau_xyz, with a 95 % interval from the fit's parameter uncertainty;",
            "# method model_upper_bound: the deviation still falls at a tenth of the record (not reached).",
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


def imu_doc(result: StaticAnalysis, finals: dict[str, FinalModel], rostopic: str,
            overbounds: dict[str, AxisOverbound] | None = None) -> dict:
    """The content of ``imu.yaml`` (see the module docstring); with ``overbounds`` its ``overbound:`` section."""
    doc = kalibr_dict(result, rostopic)
    add_final_values(doc, finals, result)
    if overbounds:
        doc["overbound"] = overbound_dict(overbounds)
    return doc


def write_imu_yaml(path: Path, result: StaticAnalysis, doc: dict, with_models: bool) -> Path:
    """Write ``imu.yaml``: the header and ``doc`` (:func:`imu_doc`)."""
    text = "\n".join(header(result, with_models)) + "\n"
    path.write_text(text + yaml.safe_dump(doc, sort_keys=False, default_flow_style=None))
    return path
