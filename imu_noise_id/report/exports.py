"""Exports of the noise figures (:data:`FORMATS`) for the filters people run, rendered by :mod:`.export_formats` from
the analysis's numbers or their overbound; files: docs/analysis.md, "Exports"."""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

from ..core.errors import InputError
from ..pipelines.analyze.numbers import PastedNumbers
from . import export_formats as fmt
from .numbers import num

FORMATS = {"openvins": ("kalibr_imu_chain.yaml", fmt.openvins), "vins": ("vins_imu.yaml", fmt.vins),
           "orbslam3": ("orbslam3_imu.yaml", fmt.orbslam3), "gtsam": ("gtsam_imu.yaml", fmt.gtsam),
           "px4": ("px4_ekf2.params", fmt.px4), "rep145": ("rep145_driver_params.yaml", fmt.rep145),
           "kalibr": ("kalibr_imu.yaml", fmt.kalibr)}
#: Where ``--overbound`` exports go, inside the exports folder (same file names).
OVERBOUND_DIR = "overbound"


def _as_in_imu_yaml(numbers: PastedNumbers) -> PastedNumbers:
    """``numbers`` to the digits ``imu.yaml`` holds them (:func:`~.numbers.num`): an analysis's exports and those
    ``export`` writes from its ``imu.yaml`` agree to the digit."""
    sensors = {}
    for name, s in numbers.sensors.items():
        axes = tuple(a if a.model is None else
                     replace(a, model=replace(a.model, noise_stddev_per_sample=num(a.model.noise_stddev_per_sample)))
                     for a in s.axes)
        sensors[name] = replace(s, noise_density=num(s.noise_density), random_walk=num(s.random_walk), axes=axes)
    return replace(numbers, rate_hz=num(numbers.rate_hz), sensors=sensors)


def write_exports(numbers: PastedNumbers, out_dir: Path, formats: tuple[str, ...] = tuple(FORMATS), *,
                  overbound: bool = False) -> list[Path]:
    """Write the ``formats`` of the analysis's ``numbers`` into ``out_dir`` (temporary name, then rename); with
    ``overbound``, the overbound's values (:meth:`PastedNumbers.overbound_values`) into ``out_dir/overbound/``.
    InputError when a format is unknown or, with ``overbound``, the numbers have no overbound."""
    unknown = [name for name in formats if name not in FORMATS]
    if unknown:
        raise InputError(f"--format {unknown[0]!r}: choose from {', '.join(FORMATS)} or all")
    if overbound:
        numbers, out_dir = numbers.overbound_values(), out_dir / OVERBOUND_DIR
    numbers = _as_in_imu_yaml(numbers)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in formats:
        filename, render = FORMATS[name]
        path = out_dir / filename
        tmp = path.with_name(f".{filename}.tmp")
        tmp.write_text(render(numbers))
        os.replace(tmp, path)
        paths.append(path)
    return paths
