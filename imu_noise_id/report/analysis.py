"""The files of an analysis, each written once from the :class:`~imu_noise_id.pipelines.analyze.AnalysisResult`:
``imu.yaml``, ``exports/`` (:mod:`.exports`), the variance CSVs, ``allan.png`` and, with a model stage,
``model.yaml``, ``allan_model.png`` and ``report.html`` (:mod:`.analysis_html`)."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path

from ..core.axes import UNITS
from ..pipelines.analyze import AnalysisResult
from .analysis_html import assemble_report, report_sections
from .exports import write_exports
from .forked import run_tasks
from .imu_yaml import imu_doc, write_imu_yaml
from .model_yaml import write_model_yaml
from .plots import plot_allan_deviation
from .plots_model import save_allan_overlay
from .variance_csv import write_variance_csvs


def write_analysis(result: AnalysisResult, out_dir: str | Path, *, meta: dict,
                   title: str = "IMU noise analysis", overbound_exports: bool = False,
                   processes: int = 1) -> dict[str, Path]:
    """Write every output of ``result`` into ``out_dir`` (created); returns the paths by file name. The exports need
    both sensors' numbers: an analysis of one sensor writes none (its warnings say so).

    ``overbound_exports``: also the exports of the overbound's values (``exports/overbound/``). ``processes``: how
    many processes may draw the figures side by side (:func:`~.forked.run_tasks`; the files are the same).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    static = result.static
    doc = imu_doc(result.numbers)
    doc["warnings"] = [*static.warnings, *result.warnings]
    paths = {"imu.yaml": write_imu_yaml(out / "imu.yaml", static, doc, bool(result.finals))}
    if set(result.numbers.sensors) == {"gyro", "accel"}:  # every filter's file needs both sensors' numbers
        for p in write_exports(result.numbers, out / "exports"):
            paths[f"exports/{p.name}"] = p
        if overbound_exports:
            for p in write_exports(result.numbers, out / "exports", overbound=True):
                paths[f"exports/{p.parent.name}/{p.name}"] = p
    for p in write_variance_csvs(static.variances, static.axes, out):
        paths[p.name] = p
    tasks: list[Callable[[], object]] = [partial(plot_allan_deviation, static, out / "allan.png")]
    if result.models:
        tasks += [partial(save_allan_overlay, out / "allan_model.png", _panels(result),
                          title="Allan deviation vs final models"), *report_sections(result, meta)]
    drawn = run_tasks(tasks, processes)  # the figures are most of the writing: drawn side by side
    paths["allan.png"] = drawn[0]
    if not result.models:
        return paths
    paths["model.yaml"] = write_model_yaml(out / "model.yaml", result.models, result.loops, meta, result.finals)
    paths["allan_model.png"] = drawn[1]
    paths["report.html"] = out / "report.html"
    paths["report.html"].write_text(assemble_report(drawn[2:], title), encoding="utf-8")
    return paths


def _panels(result: AnalysisResult) -> list[dict]:
    """The panels of ``allan_model.png``: per axis with a final model, the data's AV, its band and the model."""
    allan = result.static.allan
    return [{"tau": allan.tau, "avar": allan.variance[:, result.static.axes.index(axis)], "fit": final.fit,
             "band": result.bands[axis], "unit": UNITS.get(axis, "u"), "label": axis, "title": f"{axis}: {final.model}"}
            for axis, final in result.finals.items()]
