"""The Allan-family variances as CSV files (``allan.csv``, ``hadamard.csv``, ``total.csv``, ``modified.csv``), SI
units stated in ``#`` header lines: τ [s], variances [u²], χ² intervals, equivalent degrees of freedom."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.allan import AllanResult
from ..core.axes import UNITS


def write_variance_csv(res: AllanResult, axes: tuple[str, ...], path: Path) -> Path:
    """One Allan-family result as CSV: tau, m, then per axis the variance, CI bounds and EDF."""
    cols = ["tau_s", "m"]
    for a in axes:
        cols += [f"{a}_var", f"{a}_ci_low", f"{a}_ci_high", f"{a}_edf"]
    units = ", ".join(f"{a} [{UNITS[a]}]^2" for a in axes)
    header = [
        f"# {res.kind} variance of rate samples, dt = {res.dt:.9g} s, n = {res.n}; tau [s] = m * dt",
        f"# *_var, *_ci_low, *_ci_high in squared signal units: {units}",
        f"# *_ci_low/high: two-sided {100 * res.confidence:g} % chi-square interval; *_edf: equivalent degrees "
        "of freedom",
        ",".join(cols),
    ]
    table = np.empty((res.tau.size, len(cols)))
    table[:, 0] = res.tau
    table[:, 1] = res.m
    for j in range(len(axes)):
        table[:, 2 + 4 * j : 6 + 4 * j] = np.column_stack(
            [res.variance[:, j], res.ci_low[:, j], res.ci_high[:, j], res.edf[:, j]]
        )
    lines = [",".join(f"{v:.10g}" for v in row) for row in table]
    path.write_text("\n".join(header + lines) + "\n")
    return path


def write_variance_csvs(variances: dict[str, AllanResult], axes: tuple[str, ...], out_dir: Path) -> list[Path]:
    """``allan.csv`` and one CSV per other computed kind (``hadamard.csv``, ``total.csv``, ``modified.csv``)."""
    return [write_variance_csv(res, axes, out_dir / f"{kind}.csv") for kind, res in variances.items()]
