"""Whether this machine has the memory an ``analyze`` of a record needs, asked before the bag is decoded.

Need: :data:`PROCESS_BYTES` per process plus :data:`MAIN_BYTES_PER_SAMPLE` per message read (main process) and, per
analysed sample in each worker, :data:`EM_WORKER_BYTES_PER_SAMPLE` up to the EM's length
(:data:`~imu_noise_id.pipelines.analyze.models.EM_MAX_SAMPLES`, where the closed loop's smoother passes run) or
:data:`WORKER_BYTES_PER_SAMPLE` beyond it (the GMWM); measured: docs/analysis.md, "Quick use". Available:
``MemAvailable`` (``/proc/meminfo``), or a cgroup's ``memory.max`` − ``memory.current`` where smaller. A record is
refused only when the need exceeds it; the message gives the need and the ``--span`` that fits.
"""

from __future__ import annotations

import math
from pathlib import Path

from ..core.errors import InputError
from ..pipelines.analyze.models import EM_MAX_SAMPLES

#: RSS [bytes] of one process with the package imported (interpreter, numpy, scipy, rosbags).
PROCESS_BYTES = 130 * 2**20
#: Peak RSS [bytes] of the main process per IMU message read, over :data:`PROCESS_BYTES`.
MAIN_BYTES_PER_SAMPLE = 185
#: Peak RSS [bytes] of one worker per sample analysed by the GMWM (beyond the EM's length), over
#: :data:`PROCESS_BYTES`.
WORKER_BYTES_PER_SAMPLE = 39
#: Peak RSS [bytes] of one worker per sample analysed by the EM and the closed loop, over :data:`PROCESS_BYTES`: a whole
#: measured record whose loop reached 25 states, measured when its smoother passes held every state for every sample;
#: kept as a margin that grows with the record now that they do not (docs/analysis.md, "Quick use").
EM_WORKER_BYTES_PER_SAMPLE = 1870


def available_bytes(meminfo: Path = Path("/proc/meminfo"), cgroup: Path = Path("/sys/fs/cgroup")) -> float | None:
    """Memory [bytes] a new allocation can get: ``MemAvailable``, or the cgroup's room where smaller; None where the
    system says neither (not Linux)."""
    room = math.inf
    try:
        for line in meminfo.read_text().splitlines():
            if line.startswith("MemAvailable:"):
                room = float(line.split()[1]) * 1024.0
    except OSError:
        pass
    try:
        limit = (cgroup / "memory.max").read_text().strip()
        if limit != "max":
            room = min(room, float(limit) - float((cgroup / "memory.current").read_text().strip()))
    except (OSError, ValueError):
        pass
    return None if math.isinf(room) else room


def needed_bytes(messages: int, analysed: int, workers: int) -> float:
    """Peak memory [bytes] of an analysis of ``analysed`` of a bag's ``messages`` IMU samples with ``workers`` worker
    processes (0: all in the main process, which then also holds the fits: one worker's share)."""
    return ((1 + workers) * PROCESS_BYTES + messages * MAIN_BYTES_PER_SAMPLE
            + analysed * worker_bytes_per_sample(analysed) * max(workers, 1))


def worker_bytes_per_sample(analysed: int) -> int:
    """A worker's peak memory [bytes] per sample of an axis of ``analysed`` samples (the EM's up to its length, the
    GMWM's beyond, as ``--estimator auto`` chooses)."""
    return EM_WORKER_BYTES_PER_SAMPLE if analysed <= EM_MAX_SAMPLES else WORKER_BYTES_PER_SAMPLE


def _largest_fitting(room: float, workers: int, messages: int) -> float:
    """The most samples per axis (of a record of ``messages``) whose workers' need fits in ``room`` [bytes]: beyond
    the EM's length at the GMWM's cost when the record and the room both reach there, else at the EM's."""
    gmwm = min(room / (WORKER_BYTES_PER_SAMPLE * max(workers, 1)), messages)
    if gmwm > EM_MAX_SAMPLES:
        return gmwm
    return min(room / (EM_WORKER_BYTES_PER_SAMPLE * max(workers, 1)), EM_MAX_SAMPLES)


def check_fits(topic: str, messages: int, bag_span_s: float | None, *, span: tuple[float, float] | None,
               workers: int, available: float | None) -> None:
    """InputError when analysing ``topic``'s ``messages`` samples (over ``bag_span_s`` seconds; the ``span``
    [start, end) seconds of them when given) with ``workers`` worker processes needs more than ``available`` bytes;
    the message gives the need and the ``--span`` length that fits."""
    if available is None or messages <= 0:
        return
    rate = messages / bag_span_s if bag_span_s else None
    analysed = messages
    if span is not None and rate is not None:
        analysed = min(messages, int(max(0.0, min(span[1], bag_span_s) - span[0]) * rate) + 1)
    need = needed_bytes(messages, analysed, workers)
    if need <= available:
        return
    room = available - needed_bytes(messages, 0, workers)
    fitting = _largest_fitting(room, workers, messages)
    # whole seconds rounded down, less the sample a span's end adds (check_fits counts it)
    seconds = math.floor((fitting - 1.0) / rate) if rate is not None else 0
    advice = (f"analyse a part of it (--span 0:{seconds} fits, seconds from the first sample)"
              if seconds >= 1 else "split the bag into shorter parts")
    raise InputError(f"{topic}: analysing {analysed} samples per axis of {messages} needs about "
                     f"{need / 2**30:.1f} GiB of memory, more than the {available / 2**30:.1f} GiB available here: "
                     f"{advice}, use --jobs 1 (fewer processes), or run it on a machine with more memory")
