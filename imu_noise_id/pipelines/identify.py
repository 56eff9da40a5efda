"""``identify``: the hypothesis bank (paper 002) per axis of a static recording with its sensor's hypothesis set,
warm-up offset removed, optional grid refinement (:func:`~imu_noise_id.core.hypotheses.axis.identify_offline`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from ..core.axes import ImuSeries
from ..core.errors import InputError
from ..core.hypotheses import BankResult, HypothesisSet
from ..core.hypotheses.axis import identify_offline
from ..core.hypotheses.config import hypothesis_set_factory
from ..core.stillness import static_check

#: Rows per axis kept of the probabilities over time (for the CSV and the plot).
MAX_ROWS = 2000


@dataclass
class AxisIdentification:
    """The bank's outcome on one axis: ``result`` its probabilities and estimates over time (every ``record_every``-th
    block); ``offset`` the warm-up mean removed [u]; ``hset`` the last pass's hypothesis set; ``warmup`` [s];
    ``wn_estimate`` the warm-up's white-noise density [u/√Hz] (None: not needed); ``states`` per hypothesis its state
    estimates (mean, std) [u]; ``passes`` the passes run (1 + grid refinements)."""

    result: BankResult
    offset: float
    hset: HypothesisSet
    warmup: float
    wn_estimate: float | None
    states: dict[str, dict[str, tuple[float, float]]]
    passes: int


@dataclass
class Identification:
    """``identify`` on several axes: hypothesis file used, sampling period [s], each axis, the reader's input notes."""

    source: str
    dt: float
    axes: dict[str, AxisIdentification]
    notes: list[str] = field(default_factory=list)


def identify(series: ImuSeries, axes: list[str], hypotheses: dict[str, Any], source: str,
             refine: int = 0, *, progress: Callable[[int, int], None] | None = None,
             allow_motion: bool = False, origin_s: float = 0.0) -> Identification:
    """Run the bank on each axis of ``series`` with ``refine`` refinement passes; ``progress(done, total)`` per axis.
    The bank reads every deviation from its hypotheses as noise, so a recording the static check
    (:func:`~..core.stillness.static_check`) finds moving is refused (InputError naming its findings, the still
    stretch and ``allow_motion``: :meth:`~..core.stillness.StaticCheck.refusal`, ``origin_s`` [s] the span's start
    in the record), or with ``allow_motion`` identified with the findings among the notes."""
    if len(series) < 2:
        raise InputError(f"{series.topic or 'the IMU series'} has {len(series)} sample(s): need a recording")
    if refine < 0:
        raise InputError(f"--refine must be >= 0, got {refine}")
    dt = series.dt
    out = Identification(source, dt, {}, [f"{series.topic}: {note}" for note in series.notes])
    check = static_check(series, dt, axes=tuple(axes))
    if check.flags and not allow_motion:
        raise InputError(check.refusal(series.topic, needs="The hypothesis bank reads every deviation as noise and "
                                       "needs the IMU at rest", verb="identify", origin_s=origin_s))
    out.notes += [f"{series.topic}: not static: {m}" for m in check.flags]
    for axis in axes:
        make, warmup = hypothesis_set_factory(hypotheses, dt, axis.split("_")[0], source)
        y = series.axis(axis)
        every = max(1, len(y) // make(1.0).block // MAX_ROWS)
        result, ident, passes = identify_offline(y, make, warmup, dt, refine=refine, record_every=every)
        out.axes[axis] = AxisIdentification(result, ident.offset, ident.bank.hset, warmup, ident.wn_estimate,
                                            ident.bank.state_estimates(), passes)
        if progress is not None:
            progress(len(out.axes), len(axes))
    return out
