"""Hypothesis sets from their parsed YAML (``config/hypotheses_default.yaml``); InputError naming the offending key."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import InputError
from ..white_noise import FirstDifferences
from .model import COMPONENT_PARAMETERS, Hypothesis, HypothesisSet, ParameterPrior

_TOP_KEYS = {"gamma", "block", "warmup", "gain_tolerance", "bias_sigma", "sensors", "hypotheses"}
_SENSOR_KEYS = {"bias_sigma", "hypotheses", "gamma", "block", "warmup"}


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | str):
        raise InputError(f"{where} must be a number, got {value!r}")
    try:
        out = float(value)
    except ValueError:
        raise InputError(f"{where} must be a number, got {value!r}") from None
    if not math.isfinite(out):
        raise InputError(f"{where} must be finite, got {value!r}")
    return out


class NeedsDataError(InputError):
    """The set uses ``auto`` ranges, which need a white-noise estimate from the data."""


def white_noise_estimate(y: np.ndarray, dt: float) -> float:
    """White-noise density [u/√Hz] √(var(Δy)/2 · dt) (AV at τ₀, ``FirstDifferences``); centres ``auto`` ranges."""
    y = np.asarray(y, dtype=float).ravel()
    if y.size < 3 or not np.all(np.isfinite(y)):
        raise InputError("need at least 3 finite warm-up samples to estimate the white noise for an 'auto' range")
    diffs = FirstDifferences()
    diffs.add_series(y)
    if not diffs.variance()[0] > 0:
        raise InputError("the warm-up samples are constant: cannot centre an 'auto' white-noise range; give a range")
    return float(diffs.density(dt)[0])


def _prior(name: str, spec: Any, where: str, wn_estimate: float | None = None) -> ParameterPrior:
    where = f"{where}.priors.{name}"
    if isinstance(spec, int | float) and not isinstance(spec, bool):
        value = _number(spec, where)
        return ParameterPrior(name, value, value, 1)
    if not isinstance(spec, dict):
        raise InputError(f"{where} must be a number (known value) or {{range: [low, high], n: N, spacing: log}}")
    unknown = set(spec) - {"range", "n", "spacing", "value", "auto"}
    if unknown:
        raise InputError(f"{where}: unknown key(s) {sorted(unknown)} (use range, n, spacing, value or auto)")
    if "value" in spec:
        value = _number(spec["value"], f"{where}.value")
        return ParameterPrior(name, value, value, 1)
    if "auto" in spec:
        factor = _number(spec["auto"], f"{where}.auto")
        if name != "WN.noise_density" or factor <= 1 or "range" in spec:
            raise InputError(f"{where}.auto: only WN.noise_density may use 'auto: FACTOR' (FACTOR > 1, no range)")
        if wn_estimate is None:
            raise NeedsDataError(f"{where} is 'auto': it needs a white-noise estimate from the data")
        rng = [wn_estimate / factor, wn_estimate * factor]
    else:
        rng = spec.get("range")
    if not isinstance(rng, list | tuple) or len(rng) != 2:
        raise InputError(f"{where}.range must be [low, high]")
    low, high = _number(rng[0], f"{where}.range[0]"), _number(rng[1], f"{where}.range[1]")
    n = spec.get("n", 16)
    if isinstance(n, bool) or not isinstance(n, int):
        raise InputError(f"{where}.n must be an integer, got {n!r}")
    spacing = spec.get("spacing", "log" if "auto" in spec else "linear")
    try:
        return ParameterPrior(name, low, high, n, str(spacing))
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None


def _hypothesis(spec: Any, i: int, where: str, wn_estimate: float | None) -> Hypothesis:
    where = f"{where}.hypotheses[{i}]"
    if not isinstance(spec, dict):
        raise InputError(f"{where} must be a mapping with 'priors' (and optionally name, components, probability)")
    unknown = set(spec) - {"name", "components", "priors", "probability"}
    if unknown:
        raise InputError(f"{where}: unknown key(s) {sorted(unknown)}")
    priors = spec.get("priors")
    if not isinstance(priors, dict) or not priors:
        raise InputError(f"{where}.priors must map parameter names (e.g. GM.tau) to prior ranges")
    for name in priors:
        comp, _, par = str(name).partition(".")
        if comp not in COMPONENT_PARAMETERS or par not in COMPONENT_PARAMETERS[comp]:
            known = ", ".join(f"{c}.{p}" for c, ps in COMPONENT_PARAMETERS.items() for p in ps)
            raise InputError(f"{where}.priors: unknown parameter {name!r} (known: {known})")
    comps = spec.get("components")
    if comps is None:
        comps = list(dict.fromkeys(str(n).split(".")[0] for n in priors))
    if not isinstance(comps, list | tuple):
        raise InputError(f"{where}.components must be a list such as [WN, GM]")
    probability = _number(spec.get("probability", 1.0), f"{where}.probability")
    try:
        return Hypothesis(tuple(str(c) for c in comps),
                          tuple(_prior(str(n), s, where, wn_estimate) for n, s in priors.items()),
                          probability, str(spec.get("name", "")))
    except NeedsDataError:
        raise
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None


def hypothesis_set_from_dict(data: dict[str, Any], dt: float, sensor: str | None = None, source: str = "hypotheses",
                             wn_estimate: float | None = None) -> tuple[HypothesisSet, float]:
    """The set for ``sensor`` (``"gyro"``/``"accel"``) at input period ``dt`` [s] and the warm-up [s]; ``auto``
    white-noise ranges centred on ``wn_estimate`` [u/√Hz] (:class:`NeedsDataError` without it)."""
    unknown = set(data) - _TOP_KEYS
    if unknown:
        raise InputError(f"{source}: unknown top-level key(s) {sorted(unknown)} (known: {sorted(_TOP_KEYS)})")
    section: dict[str, Any] = {}
    where = source
    if "sensors" in data:
        sensors = data["sensors"]
        if not isinstance(sensors, dict):
            raise InputError(f"{source}.sensors must map sensor types (gyro, accel) to hypothesis sets")
        if sensor is None or sensor not in sensors:
            raise InputError(f"{source}.sensors has no entry for {sensor!r} (has {sorted(sensors)})")
        section = sensors[sensor]
        where = f"{source}.sensors.{sensor}"
        if not isinstance(section, dict):
            raise InputError(f"{where} must be a mapping")
        bad = set(section) - _SENSOR_KEYS
        if bad:
            raise InputError(f"{where}: unknown key(s) {sorted(bad)} (known: {sorted(_SENSOR_KEYS)})")
    merged = {k: v for k, v in data.items() if k != "sensors"} | section
    hyps = merged.get("hypotheses")
    if not isinstance(hyps, list) or not hyps:
        raise InputError(f"{where}.hypotheses must be a non-empty list")
    hypotheses = tuple(_hypothesis(h, i, where, wn_estimate) for i, h in enumerate(hyps))
    block = merged.get("block", 1)
    if isinstance(block, bool) or not isinstance(block, int):
        raise InputError(f"{where}.block must be an integer >= 1, got {block!r}")
    warmup = _number(merged.get("warmup", 1.0), f"{where}.warmup")
    if warmup < 0:
        raise InputError(f"{where}.warmup must be >= 0 s, got {warmup}")
    try:
        hset = HypothesisSet(
            hypotheses, dt=float(dt), gamma=_number(merged.get("gamma", 0.8), f"{where}.gamma"), block=block,
            bias_sigma=_number(merged.get("bias_sigma", 1.0), f"{where}.bias_sigma"),
            gain_tolerance=_number(merged.get("gain_tolerance", 1e-10), f"{where}.gain_tolerance"),
        )
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None
    return hset, warmup


def hypothesis_set_factory(data: dict[str, Any], dt: float, sensor: str | None = None,
                           source: str = "hypotheses") -> tuple[Callable[[float | None], HypothesisSet], float]:
    """A function white-noise estimate → hypothesis set (checked now) and the warm-up [s], for ``AxisIdentifier``."""
    try:
        _, warmup = hypothesis_set_from_dict(data, dt, sensor, source, None)
    except NeedsDataError:
        _, warmup = hypothesis_set_from_dict(data, dt, sensor, source, 1.0)

    def make(wn_estimate: float | None) -> HypothesisSet:
        return hypothesis_set_from_dict(data, dt, sensor, source, wn_estimate)[0]

    return make, warmup
