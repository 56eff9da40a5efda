"""Exports of the noise figures (:data:`FORMATS`) for the filters people run, rendered by :mod:`.export_formats` from
``imu.yaml``'s numbers or its ``overbound:`` section (:func:`overbound_doc`); files: docs/analysis.md, "Exports"."""

from __future__ import annotations

import os
from pathlib import Path

from ..core.constants import CONFIDENCE_95
from ..core.errors import InputError
from . import export_formats as fmt

REQUIRED = ("gyroscope_noise_density", "gyroscope_random_walk", "accelerometer_noise_density",
            "accelerometer_random_walk", "update_rate")

FORMATS = {"openvins": ("kalibr_imu_chain.yaml", fmt.openvins), "vins": ("vins_imu.yaml", fmt.vins),
           "orbslam3": ("orbslam3_imu.yaml", fmt.orbslam3), "gtsam": ("gtsam_imu.yaml", fmt.gtsam),
           "px4": ("px4_ekf2.params", fmt.px4), "rep145": ("rep145_driver_params.yaml", fmt.rep145),
           "kalibr": ("kalibr_imu.yaml", fmt.kalibr)}
#: Where ``--overbound`` exports go, inside the exports folder (same file names).
OVERBOUND_DIR = "overbound"


def overbound_doc(doc: dict) -> dict:
    """``doc`` with its Kalibr keys and per-axis values replaced by its ``overbound:`` section's, the per-sample
    standard deviations dropped (a WN + RW has no low-pass: REP-145 then uses N·√f) and ``overbound_of`` saying what the
    values are; InputError without an ``overbound:`` section."""
    ob = doc.get("overbound")
    if not isinstance(ob, dict) or not all(isinstance(ob.get(k), int | float) for k in REQUIRED[:4]):
        raise InputError("imu.yaml has no 'overbound:' section with the four Kalibr numbers: rerun imu-noise-id "
                         "analyze (it writes one) to export the overbound")
    out = {k: v for k, v in doc.items() if "per_sample" not in k and not k.endswith("_method_xyz")}
    for key in REQUIRED[:4]:
        out[key] = ob[key]
        if f"{key}_xyz" in ob:
            out[f"{key}_xyz"] = ob[f"{key}_xyz"]
    lo, hi = ob.get("tau_range_s", [float("nan")] * 2)
    level = float(doc.get("confidence_level", CONFIDENCE_95))
    out["overbound_of"] = (f"the smallest WN+RW whose Allan variance lies above the data's upper "
                           f"{100 * level:g} % bound and the final model's AV at "
                           f"every tau in [{lo:g}, {hi:g}] s, not below the fitted values; inflation over them: "
                           f"{ob.get('inflation_summary', 'see imu.yaml')}")
    return out


def write_exports(doc: dict, out_dir: Path, formats: tuple[str, ...] = tuple(FORMATS), *,
                  overbound: bool = False) -> list[Path]:
    """Write the ``formats`` from the ``imu.yaml`` content ``doc`` into ``out_dir`` (temporary name, then rename); with
    ``overbound``, the overbound's values into ``out_dir/overbound/``. InputError when ``doc`` lacks a number an export
    needs (or the overbound section) or a format is unknown."""
    missing = [k for k in REQUIRED if not isinstance(doc.get(k), int | float)]
    if missing:
        raise InputError(f"imu.yaml lacks {', '.join(missing)}: rerun imu-noise-id analyze")
    unknown = [name for name in formats if name not in FORMATS]
    if unknown:
        raise InputError(f"--format {unknown[0]!r}: choose from {', '.join(FORMATS)} or all")
    if overbound:
        doc, out_dir = overbound_doc(doc), out_dir / OVERBOUND_DIR
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in formats:
        filename, render = FORMATS[name]
        path = out_dir / filename
        tmp = path.with_name(f".{filename}.tmp")
        tmp.write_text(render(doc))
        os.replace(tmp, path)
        paths.append(path)
    return paths
