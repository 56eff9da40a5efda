"""An ``analyze`` results folder read back as ``compare``'s reference: ``imu.yaml`` (per-axis N, interval, rate,
topic: what the reference needs, not the exports' four Kalibr numbers) and, where present, ``model.yaml`` (final
components, the loop's sinusoid regressors)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import yaml

from ..core.axes import AXES, sensor_of
from ..core.errors import InputError
from ..core.noise.base import Component
from ..core.noise.components import COMPONENT_TYPES
from ..core.watch.axis_reference import AxisReference
from ..pipelines.analyze.numbers import KALIBR_PREFIX


@dataclass(frozen=True)
class Reference:
    """A results folder as a reference: per axis what it should look like, the rate [Hz] and topic it came from."""

    axes: dict[str, AxisReference]
    rate_hz: float
    topic: str | None
    source: Path


def _load(path: Path) -> dict:
    try:
        doc = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise InputError(f"reference: cannot read {path} ({exc}): give the folder `analyze` wrote") from None
    if not isinstance(doc, dict):
        raise InputError(f"reference: {path} is not an analyze output (no mapping at its top)")
    return doc


def _components(final: dict) -> list[Component] | None:
    """The final model's components from its model.yaml entry; None when one cannot be rebuilt."""
    out = []
    for entry in final.get("components", []):
        cls = COMPONENT_TYPES.get(entry.get("type"))
        if cls is None or not all(p in entry for p in cls.parameter_names):
            return None
        try:
            out.append(cls(**{p: float(entry[p]) for p in cls.parameter_names}))
        except (TypeError, ValueError):
            return None
    return out or None


def _known_lines(axis_entry: dict) -> tuple[float, ...]:
    steps = axis_entry.get("loop") or []
    regressors = steps[-1].get("regressors", {}) if steps else {}
    return tuple(float(v["frequency"]) for k, v in regressors.items() if k.startswith("SIN") and "frequency" in v)


def _random_walk_ci(imu: dict, axis: str) -> tuple[float, float] | None:
    """K's 95 % interval [u/s/√Hz] of ``axis`` in ``imu`` (imu.yaml), None where it gives none."""
    try:
        lo, hi = (float(v) for v in imu[f"{KALIBR_PREFIX[sensor_of(axis)]}_random_walk_ci_xyz"][AXES.index(axis) % 3])
    except (KeyError, IndexError, TypeError, ValueError):
        return None
    return (lo, hi) if math.isfinite(hi) else None


def read_reference(path: str | Path) -> Reference:
    """The reference in ``path`` (a results folder, or its ``imu.yaml``).

    Raises
    ------
    InputError
        No readable imu.yaml, or one without per-axis noise densities.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"reference: {path} does not exist: give the folder `analyze` wrote (or its imu.yaml)")
    folder = path if path.is_dir() else path.parent
    imu = _load(folder / "imu.yaml")
    model = _load(folder / "model.yaml").get("axes", {}) if (folder / "model.yaml").exists() else {}
    axes = {}
    for axis in AXES:
        key = f"{KALIBR_PREFIX[sensor_of(axis)]}_noise_density"
        i = AXES.index(axis) % 3
        try:
            value = float(imu[f"{key}_xyz"][i])
            ci = tuple(float(v) for v in imu.get(f"{key}_ci_xyz", [[math.nan, math.nan]] * 3)[i])
        except (KeyError, IndexError, TypeError, ValueError):
            raise InputError(f"reference: {folder / 'imu.yaml'} has no per-axis {key}_xyz: give the folder "
                             "`analyze` wrote") from None
        entry = model.get(axis, {})
        components = _components(entry["final"]) if "final" in entry else None
        axes[axis] = AxisReference(value, ci, components, _known_lines(entry), _random_walk_ci(imu, axis))
    rate = imu.get("update_rate")
    if not isinstance(rate, (int, float)) or not rate > 0:
        raise InputError(f"reference: {folder / 'imu.yaml'} has no update_rate")
    return Reference(axes, float(rate), imu.get("rostopic"), folder)
