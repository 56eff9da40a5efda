"""``imu.yaml``: the numbers users paste into Kalibr-style configs, written once from an analysis result.

The four Kalibr keys are the max over the sensor's three axes. With a model stage they come from the fitted
models (WN → noise density, RW → random walk) where every axis of the sensor has that component, the Allan-slope
values staying beside them as ``<key>_allan``; without it, from the Allan slopes. Units are SI and stated in the
header comment.
"""

from __future__ import annotations

from pathlib import Path

import yaml

from ..core.axes import ACCEL_AXES, GYRO_AXES
from ..core.estimation.selection import kalibr_values
from ..pipelines.analyze.models import AxisModel
from ..pipelines.analyze.static import StaticAnalysis, kalibr_parameters
from .numbers import num

#: How the one number per sensor that Kalibr wants is made from the three axes.
KALIBR_COMBINE = "max"
_PREFIX = {"gyro": "gyroscope", "accel": "accelerometer"}
_SENSORS = (("gyro", GYRO_AXES), ("accel", ACCEL_AXES))


def kalibr_dict(result: StaticAnalysis, rostopic: str) -> dict:
    """Kalibr ``imu.yaml`` content from the Allan slopes: its six keys plus per-axis values, CIs and methods."""
    doc: dict = {k: num(v) for k, v in kalibr_parameters(result, KALIBR_COMBINE).items()}
    doc["update_rate"] = num(result.rate_hz)
    doc["rostopic"] = rostopic
    doc["confidence_level"] = result.allan.confidence
    for sensor, axes in _SENSORS:
        for parameter in ("noise_density", "random_walk"):
            key = f"{_PREFIX[sensor]}_{parameter}"
            comps = [getattr(result.slopes[a], parameter) for a in axes]
            doc[f"{key}_xyz"] = [num(c.value) for c in comps]
            doc[f"{key}_ci_xyz"] = [[num(c.ci[0]), num(c.ci[1])] for c in comps]
            doc[f"{key}_method_xyz"] = [c.method for c in comps]
    return doc


def add_model_values(doc: dict, models: dict[str, AxisModel]) -> None:
    """Put the fitted models' values into the Kalibr keys (see the module docstring), in place.

    A sensor keeps its Allan value when a fitted axis has no WN (noise density) or no RW (random walk) — e.g. a
    WN+GM model has no Kalibr random walk; ``<key>_source`` says which one each number is.
    """
    for sensor, axes in _SENSORS:
        if not all(a in models for a in axes):
            continue
        values = [kalibr_values(models[a].fit) for a in axes]
        for parameter in ("noise_density", "random_walk"):
            key = f"{_PREFIX[sensor]}_{parameter}"
            per_axis = [v[parameter] for v in values]
            doc[f"{key}_em_xyz"] = [None if v is None else num(v) for v in per_axis]
            doc[f"{key}_allan"] = doc[key]
            if all(v is not None for v in per_axis):
                doc[key] = num(max(per_axis))
                doc[f"{key}_source"] = "EM model (max over axes); Allan-slope value in *_allan"
            else:
                doc[f"{key}_source"] = "Allan slope (the selected model has no such component on every axis)"


def header(result: StaticAnalysis, with_models: bool) -> list[str]:
    """The comment lines at the top of ``imu.yaml`` (units, conventions, data)."""
    conf = result.allan.confidence
    lines = [
        "# IMU noise parameters for Kalibr / VIO, from the Allan variance (imu-noise-id analyze).",
        "# Units: *_noise_density: gyroscope rad/s/sqrt(Hz), accelerometer m/s^2/sqrt(Hz);",
        "#        *_random_walk: gyroscope rad/s^2/sqrt(Hz), accelerometer m/s^3/sqrt(Hz); update_rate Hz.",
        f"# The four Kalibr numbers are the {KALIBR_COMBINE} over the sensor's x, y, z axes; per-axis values are in",
        "# the *_xyz keys. White noise is the -1/2 slope line read at tau = 1 s, random walk the +1/2 slope line",
        f"# at tau = 3 s; *_ci_xyz: {100 * conf:g} % confidence intervals; method upper_bound = slope not reached.",
        f"# Data: {result.n} samples, {result.duration_s:.1f} s at {result.rate_hz:.6g} Hz from {result.topic or '?'}.",
    ]
    if with_models:
        lines += [
            "# EM stage: the Kalibr keys come from the fitted models (model.yaml) where every axis has the",
            "# component (WN -> noise density, RW -> random walk); the Allan-slope values are in *_allan.",
        ]
    return lines


def write_imu_yaml(path: Path, result: StaticAnalysis, models: dict[str, AxisModel], rostopic: str) -> Path:
    """Write ``imu.yaml`` (see the module docstring)."""
    doc = kalibr_dict(result, rostopic)
    add_model_values(doc, models)
    text = "\n".join(header(result, bool(models))) + "\n"
    path.write_text(text + yaml.safe_dump(doc, sort_keys=False, default_flow_style=None))
    return path
