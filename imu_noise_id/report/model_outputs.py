"""Outputs of the EM stage of ``analyze``: ``model.yaml``, ``allan_model.png`` and the model-based values in
``imu.yaml`` (Kalibr keys from the selected model, the Allan-slope values kept beside them as ``*_allan``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from ..core.axes import ACCEL_AXES, GYRO_AXES, UNITS
from ..core.estimation.fit import FitResult, SelectionResult, kalibr_values, simulate_allan_band
from .model_yaml import write_model_yaml
from .plots_model import save_allan_overlay

_KEYS = {"gyro": "gyroscope", "accel": "accelerometer"}


def update_kalibr_yaml(path: Path, fits: dict[str, FitResult]) -> Path:
    """Rewrite ``imu.yaml``'s four Kalibr numbers from the fitted models (max over the sensor's axes, like the
    Allan values), keep the Allan-slope values as ``<key>_allan``, add per-axis ``<key>_em_xyz``.

    A sensor keeps its Allan value when a fitted axis has no WN (noise density) or no RW (random walk) — e.g. a
    WN+GM model has no Kalibr random walk; ``<key>_source`` says which one each number is.
    """
    text = path.read_text()
    header = [line for line in text.splitlines() if line.startswith("#")]
    doc = yaml.safe_load(text) or {}
    for sensor, axes in (("gyro", GYRO_AXES), ("accel", ACCEL_AXES)):
        if not all(a in fits for a in axes):
            continue
        values = [kalibr_values(fits[a]) for a in axes]
        for parameter in ("noise_density", "random_walk"):
            key = f"{_KEYS[sensor]}_{parameter}"
            per_axis = [v[parameter] for v in values]
            doc[f"{key}_em_xyz"] = [None if v is None else float(f"{v:.6g}") for v in per_axis]
            if key in doc:
                doc[f"{key}_allan"] = doc[key]
            if all(v is not None for v in per_axis):
                doc[key] = float(f"{max(per_axis):.6g}")
                doc[f"{key}_source"] = "EM model (max over axes); Allan-slope value in *_allan"
            else:
                doc[f"{key}_source"] = "Allan slope (the selected model has no such component on every axis)"
    header.append("# EM stage: the Kalibr keys come from the fitted models (model.yaml) where every axis has the")
    header.append("# component (WN -> noise density, RW -> random walk); the Allan-slope values are in *_allan.")
    path.write_text("\n".join(header) + "\n" + yaml.safe_dump(doc, sort_keys=False, default_flow_style=None))
    return path


def write_model_outputs(
    out_dir: str | Path, fits: dict[str, FitResult], selections: dict[str, SelectionResult],
    avar: dict[str, tuple[np.ndarray, np.ndarray]], *, meta: dict | None = None, n_sim: int = 20,
) -> dict[str, Path]:
    """``model.yaml``, ``allan_model.png`` (AD of each axis, the fit's theoretical AD and ``n_sim`` simulations
    of the fit, as paper 000 figs. 4, 6, 7) and, when present, the EM values in ``imu.yaml``.

    ``avar`` maps an axis to its empirical (tau [s], Allan variance [u²]).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"model.yaml": write_model_yaml(out / "model.yaml", fits, selections, meta)}
    panels = []
    for k, (axis, fit) in enumerate(fits.items()):
        tau, av = avar[axis]
        band = simulate_allan_band(fit, fit.n, tau, n_sim=n_sim, seed=k)
        panels.append({"tau": tau, "avar": av, "fit": fit, "band": band, "unit": UNITS.get(axis, "u"),
                       "label": axis, "title": f"{axis}: {fit.model}"})
    if panels:
        paths["allan_model.png"] = save_allan_overlay(out / "allan_model.png", panels,
                                                      title="Allan deviation vs fitted models")
    kalibr = out / "imu.yaml"
    if kalibr.exists():
        paths["imu.yaml"] = update_kalibr_yaml(kalibr, fits)
    return paths
