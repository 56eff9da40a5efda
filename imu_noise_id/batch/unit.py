"""One unit of work on a Dask worker: read the bag, run ``analyze`` with the :class:`~.units.BatchOptions`, write
``OUT/<unit name>/`` as ``analyze`` does plus ``unit.json`` (content hash, options, fleet rows) via a temporary folder
renamed into place, return the rows. Never raises: a failure is the outcome ``failed`` with its one-line message.
"""

from __future__ import annotations

import json
import math
import shutil
import time
import traceback
import uuid
from dataclasses import asdict, dataclass, field
from pathlib import Path

from ..core.axes import AXES
from ..core.errors import InputError
from ..report.numbers import num
from .units import BatchOptions, Unit, content_hash

MARKER = "unit.json"


@dataclass
class UnitOutcome:
    """What a unit produced: its status (``ok``, ``failed``, ``skipped``), error, fleet rows and time."""

    name: str
    bag: str
    topic: str | None
    status: str
    key: str
    rows: list[dict] = field(default_factory=list)
    error: str = ""
    seconds: float = 0.0


def _num(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def fleet_rows(unit: Unit, result, warnings: list[str], beyond: dict | None = None) -> list[dict]:
    """One row per axis: imu.yaml's per-axis N and K with intervals and methods (``result.numbers``), B with its method,
    the loop, the ``warnings`` of that axis and of the whole unit (those naming another axis, "gyro_x: …", left out),
    and ``beyond`` (axis → NoiseLevel of the test against the spec's limit): the density over the limit and, when the
    test holds the axis beyond it, since when [s]."""
    rows = []
    for axis in result.static.axes:
        others = tuple(f"{other}: " for other in AXES if other != axis)
        row = {"bag": str(unit.bag), "topic": result.static.topic, "unit": unit.name, "axis": axis,
               "status": "ok", "error": "", "rate_hz": _num(num(result.static.rate_hz)),
               "duration_s": _num(result.static.duration_s),
               "warnings": " | ".join(w for w in warnings if not w.startswith(others))}
        pasted = result.numbers.axis(axis)
        n, k = pasted.noise_density, pasted.random_walk
        row |= {"noise_density": _num(n.value), "noise_density_lo": _num(n.ci95[0]),
                "noise_density_hi": _num(n.ci95[1]), "noise_density_method": n.method,
                "random_walk": _num(k.value), "random_walk_lo": _num(k.ci95[0]), "random_walk_hi": _num(k.ci95[1]),
                "random_walk_method": k.method}
        final = result.finals.get(axis)
        if final is not None:
            b = final.bias_instability
            row |= {"model": final.model, "bias_instability": _num(b.value), "bias_instability_lo": _num(b.ci95[0]),
                    "bias_instability_hi": _num(b.ci95[1]), "bias_instability_method": b.method(),
                    "source": final.source}
        else:
            row |= {"model": "allan", "bias_instability": None, "bias_instability_lo": None,
                    "bias_instability_hi": None, "bias_instability_method": None, "source": "Allan slopes"}
        loop = result.loops.get(axis)
        row |= {"loop_verdict": loop.verdict if loop else "", "loop_passed": bool(loop.passed) if loop else None}
        level = (beyond or {}).get(axis)
        if level is not None:
            row |= {"noise_spec_ratio": _num(level.ratio),
                    "noise_beyond_spec_since_s": level.alarm.since_s if level.sustained else None}
        rows.append(row)
    return rows


def failed_row(unit: Unit, error: str) -> dict:
    """The one row of a failed unit."""
    return {"bag": str(unit.bag), "topic": unit.topic, "unit": unit.name, "axis": None, "status": "failed",
            "error": error}


def finished(out_root: Path, unit: Unit, key: str) -> UnitOutcome | None:
    """The outcome recorded by an earlier run of the same unit with the same content hash, if any."""
    marker = out_root / unit.name / MARKER
    try:
        doc = json.loads(marker.read_text())
    except (OSError, ValueError):
        return None
    if doc.get("key") != key or doc.get("status") != "ok":
        return None
    return UnitOutcome(unit.name, str(unit.bag), unit.topic, "skipped", key, doc.get("rows", []))


def _replace_folder(tmp: Path, final: Path) -> None:
    """Move ``tmp`` to ``final``, the old folder (if any) out of the way first and removed only afterwards."""
    old = final.with_name(f".{final.name}.old-{uuid.uuid4().hex[:8]}")
    if final.exists():
        final.rename(old)
    tmp.rename(final)
    shutil.rmtree(old, ignore_errors=True)


def _title(unit: Unit) -> str:
    """The report's title, as ``analyze`` gives it: the bag's name (and the topic when the bag has several)."""
    several = bool(unit.topic) and unit.name.endswith(unit.topic.replace("/", "_"))
    return f"IMU noise analysis: {unit.bag.name}" + (f" {unit.topic}" if several else "")


def _beyond_spec(imu, result, options: BatchOptions) -> dict:
    """The test against the spec's limits (``BatchOptions.limits``) with each axis's own analysis as the shape: its
    pasted N and final model (white noise of the Allan N without one)."""
    from ..core.watch.axis_reference import AxisReference
    from ..pipelines.compare import beyond_spec

    if not options.limits:
        return {}
    if options.analysis.span is not None:
        imu = imu.between(*options.analysis.span)
    own = {}
    for axis in result.static.axes:
        final = result.finals.get(axis)
        if final is not None:
            own[axis] = AxisReference(final.noise_density.value, final.noise_density.ci95, final.fit.components)
        else:
            n = result.static.slopes[axis].noise_density
            own[axis] = AxisReference(n.value, n.ci)
    return beyond_spec(imu, result.static.dt, own, options.limits)


def run_unit(unit: Unit, options: BatchOptions, out_root: str) -> UnitOutcome:
    """Analyse one unit (module docstring). Runs on a Dask worker; never raises."""
    from ..bag.reader import read_static
    from ..pipelines.analyze import analyze
    from ..report.analysis import write_analysis
    from ..report.results_folder import RunRecord, now, stamp

    start = time.perf_counter()
    started = now()
    out = Path(out_root)
    key = ""
    try:
        key = content_hash(unit, options)
        recording = read_static(unit.bag, topic=unit.topic, temperature_topic=options.temperature_topic,
                                rate_hz=options.rate)
        result = analyze(recording.imu, recording.temperature, options.analysis)
        tmp = out / f".{unit.name}.tmp-{uuid.uuid4().hex[:8]}"
        models = options.analysis.models
        meta = {"source": str(unit.bag), "topic": recording.imu.topic, "command": "batch", "model": models.model,
                "estimator": models.estimator, "notes": recording.notes}
        write_analysis(result, tmp, meta=meta, title=_title(unit),
                       overbound_exports=options.overbound_exports)
        record = RunRecord(command="batch", argv=[], source=str(unit.bag), topic=recording.imu.topic,
                           options=options.as_dict(), started=started, finished=now(), completed=True).as_dict()
        for path in sorted(p for p in tmp.rglob("*") if p.is_file()):
            stamp(path, path.relative_to(tmp).as_posix(), record)
        warnings = list(result.static.warnings) + list(result.warnings)
        outcome = UnitOutcome(unit.name, str(unit.bag), recording.imu.topic, "ok", key,
                              fleet_rows(unit, result, warnings, _beyond_spec(recording.imu, result, options)))
        outcome.seconds = time.perf_counter() - start
        (tmp / MARKER).write_text(json.dumps({**asdict(outcome), "options": options.as_dict()}, indent=1))
        _replace_folder(tmp, out / unit.name)
        return outcome
    except InputError as exc:
        error = str(exc)
    except Exception as exc:  # a unit's failure is recorded, the batch goes on
        error = f"internal error: {type(exc).__name__}: {exc} ({traceback.extract_tb(exc.__traceback__)[-1].name})"
    return UnitOutcome(unit.name, str(unit.bag), unit.topic, "failed", key, [failed_row(unit, error)], error,
                       time.perf_counter() - start)
