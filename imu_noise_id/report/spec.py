"""A datasheet specification: the largest allowed value per sensor and parameter, YAML in SI units::

    gyro: {noise_density: 3.0e-4, random_walk: 4.0e-5, bias_instability: 1.0e-4}
    accel: {noise_density: 2.0e-3}

(``noise_density`` [u/√Hz], ``random_walk`` [u/s/√Hz], ``bias_instability`` [u]; every key optional)."""

from __future__ import annotations

from pathlib import Path

import yaml

from ..core.errors import InputError

#: Sensors and parameters a specification may limit.
SENSORS = ("gyro", "accel")
PARAMETERS = ("noise_density", "random_walk", "bias_instability")

Spec = dict[str, dict[str, float]]


def read_spec(path: str | Path, option: str = "--spec") -> Spec:
    """The specification in ``path`` (module docstring), {sensor: {parameter: limit}}.

    Raises
    ------
    InputError
        Unreadable, or not of that form; the message names ``option`` and the file.
    """
    try:
        doc = yaml.safe_load(Path(path).read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise InputError(f"{option} {str(path)!r}: cannot read it ({exc})") from None
    ok = isinstance(doc, dict) and all(
        k in SENSORS and isinstance(v, dict) and all(
            p in PARAMETERS and isinstance(x, int | float) and not isinstance(x, bool) and x > 0
            for p, x in v.items()) for k, v in doc.items())
    if not ok:
        raise InputError(f"{option} {str(path)!r}: expected {{gyro: {{noise_density: …, random_walk: …, "
                         "bias_instability: …}, accel: {…}}} with positive numbers in SI units")
    return {sensor: {p: float(x) for p, x in limits.items()} for sensor, limits in doc.items()}


def noise_density_limits(spec: Spec) -> dict[str, float]:
    """The ``noise_density`` limit [u/√Hz] of each sensor the specification gives one for."""
    return {sensor: limits["noise_density"] for sensor, limits in spec.items() if "noise_density" in limits}
