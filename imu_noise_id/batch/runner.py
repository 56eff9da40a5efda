"""Submitting the units to a Dask cluster (one task each, the same :class:`~.units.BatchOptions`) and gathering the
fleet table; a unit whose outputs are on disk with the same content hash is not submitted again (docs/batch.md)."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..pipelines.analyze import AnalyzeOptions
from .unit import UnitOutcome, finished, run_unit
from .units import BatchOptions, Unit, content_hash


@dataclass(frozen=True)
class BatchProgress:
    """Where a batch stands: units done (run now), failed among them, skipped (unchanged), still running or queued
    on the cluster, total, wall time [s] and the estimated time left [s]."""

    done: int
    failed: int
    skipped: int
    running: int
    total: int
    elapsed_s: float
    left_s: float


Progress = Callable[[BatchProgress], None]


@dataclass
class BatchResult:
    """The outcome of every unit in input order, their fleet rows, and the wall time [s]."""

    outcomes: list[UnitOutcome]
    seconds: float

    @property
    def rows(self) -> list[dict]:
        return [row for o in self.outcomes for row in o.rows]


def open_client(scheduler: str | None = None, workers: int = 2, memory_limit: str = "4GiB"):
    """A Dask client: to ``scheduler`` (``tcp://HOST:PORT``) if given, else to a new local cluster on 127.0.0.1 of
    ``workers`` single-threaded worker processes, each limited to ``memory_limit``."""
    from dask.distributed import Client, LocalCluster

    if scheduler:
        return Client(scheduler, timeout="30s")
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address="127.0.0.1:0", worker_dashboard_address="127.0.0.1:0",
                           memory_limit=memory_limit, silence_logs=logging.ERROR)
    return Client(cluster)


def run_batch(units: list[Unit], options: BatchOptions | AnalyzeOptions, out_root: str | Path, client, *,
              progress: Progress | None = None) -> BatchResult:
    """Run every unit not already finished (module docstring) on ``client`` with ``options`` (an
    :class:`AnalyzeOptions` alone: without ``--rate`` and the overbound's exports); never raises for a unit's
    failure."""
    from dask.distributed import as_completed

    if isinstance(options, AnalyzeOptions):
        options = BatchOptions(options)
    start = time.perf_counter()
    out = Path(out_root)
    out.mkdir(parents=True, exist_ok=True)
    outcomes: dict[str, UnitOutcome] = {}
    futures = {}
    for unit in units:
        try:
            key = content_hash(unit, options)
        except OSError:
            key = ""
        done = finished(out, unit, key) if key else None
        if done is not None:
            outcomes[unit.name] = done
        else:
            futures[client.submit(run_unit, unit, options, str(out), pure=False, retries=1,
                                  key=f"imu-noise-id-unit-{unit.name}-{key[:12] or 'x'}-{time.time_ns()}")] = unit
    skipped, failed = len(outcomes), 0
    for ran, future in enumerate(as_completed(list(futures)), start=1):
        unit = futures[future]
        try:
            outcome = future.result()
        except Exception as exc:  # the task itself was lost (e.g. its worker killed more often than allowed)
            outcome = UnitOutcome(unit.name, str(unit.bag), unit.topic, "failed", "",
                                  [{"bag": str(unit.bag), "topic": unit.topic, "unit": unit.name, "axis": None,
                                    "status": "failed", "error": f"task lost: {type(exc).__name__}: {exc}"}],
                                  f"task lost: {exc}")
        outcomes[unit.name] = outcome
        failed += outcome.status == "failed"
        if progress is not None:
            elapsed = time.perf_counter() - start
            left = len(futures) - ran
            progress(BatchProgress(len(outcomes) - skipped, failed, skipped, left, len(units), elapsed,
                                   elapsed / ran * left))
    return BatchResult([outcomes[u.name] for u in units], time.perf_counter() - start)
