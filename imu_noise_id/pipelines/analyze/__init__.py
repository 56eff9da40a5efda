"""``analyze`` as one pipeline: a static recording in, one :class:`AnalysisResult` out; data flows down once.

Stages, each run once on data in memory: 1. the Allan stage (:mod:`.static`); 2. the model stage (:mod:`.models`:
selection by BIC with the constrained EM, starts fitted to stage 1's AV, or the GMWM by WIC, or both); 3. the closed
loop (:mod:`imu_noise_id.pipelines.loop`) from each axis's selected EM fit at the recording's own rate (not for GMWM
fits); 4. the final model (:mod:`.final`); 5. the AV range of each final model; 6. the overbound
(:mod:`.overbound`); 7. the resolution (:mod:`.resolution`: an unresolved axis gives its data overbound's K, and its
N unless the data confirm the model's, as upper bounds). Stages 2–5 of one axis run in worker processes on long
records (``AnalyzeOptions.jobs``), which read the recording from memory-mapped files (:mod:`.mapped`), the results in
axis order and the same as serially. The report layer (:mod:`imu_noise_id.report.analysis`) writes the files from the
result.
"""

from __future__ import annotations

import contextlib
import math
import multiprocessing
import os
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path

from ... import heap
from ...core.allan import DEFAULT_CONFIDENCE, DEFAULT_PER_DECADE, KINDS
from ...core.axes import AXES, SENSORS, ImuSeries, ScalarSeries
from ...core.diagnostics.av_band import ModelAvRange, model_av_range
from ...core.errors import InputError
from ...core.estimation.em.results import FitResult
from ...core.estimation.em.uncertainty import PROFILE_BUDGET
from ...core.estimation.readouts.passband import PassbandLevel, passband_level
from ..loop import ImuLoop, LoopResult
from .final import FinalModel, final_model
from .mapped import MappedImu
from .models import AUTO, AxisModel, ModelStage, finish_axis, fit_axis
from .numbers import PastedNumbers, pasted_numbers
from .overbound import DEFAULT_HORIZON_S, AxisOverbound, check_horizon, overbounds
from .resolution import resolve_axis
from .static import StaticAnalysis, analyze_static

#: With ``jobs=0`` (automatic) a record of fewer samples per axis runs its axes in this process (docs/analysis.md,
#: "Why only the shortest records run their axes in one process").
PARALLEL_MIN_SAMPLES = 10_000

Progress = Callable[[int, int], None]
#: Called when an axis is done: (axis, its model-stage fit, its loop or None).
OnAxis = Callable[[str, FitResult, LoopResult | None], None]


@dataclass(frozen=True)
class AnalyzeOptions:
    """Everything ``analyze`` can be asked (the CLI's options).

    Attributes
    ----------
    kinds, per_decade, confidence, allow_motion
        Allan stage: variances computed, averaging times per decade, interval level, analyse a moving record.
    models
        Model stage (``models.model == "none"``: Allan only, no loop).
    axes
        The axes stages 2–7 run on; the Allan stage runs on every axis of their sensors (:attr:`sensors`).
    loop, loop_alpha, loop_max_steps
        Run the closed loop after the model stage; its detectors' level and most effects added per axis (None: the
        loop's defaults, :func:`~imu_noise_id.pipelines.loop.run.run_closed_loop`).
    finals
        Run stages 4–7 (final model, band, overbound, resolution); False: the model stage (and loop) only, as
        ``fit`` asks.
    horizon_s
        End of the overbound's τ range [s] (it starts at the sampling period).
    jobs
        Worker processes for stages 2–5: 0 one per core (at most one per axis) from :data:`PARALLEL_MIN_SAMPLES`
        samples per axis, else in this process; 1 all in this process.
    span
        Analyse only ``span[0]`` to ``span[1]`` [s] after the first sample; None: the whole record.
    """

    kinds: tuple[str, ...] = KINDS
    per_decade: int = DEFAULT_PER_DECADE
    confidence: float = DEFAULT_CONFIDENCE
    allow_motion: bool = False
    models: ModelStage = field(default_factory=ModelStage)
    axes: tuple[str, ...] = AXES
    loop: bool = True
    loop_alpha: float | None = None
    loop_max_steps: int | None = None
    finals: bool = True
    horizon_s: float = DEFAULT_HORIZON_S
    jobs: int = 0
    span: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if self.jobs < 0:
            raise InputError(f"--jobs must be >= 0 (0: one per core), got {self.jobs}")
        if not (math.isfinite(self.horizon_s) and self.horizon_s > 0):
            raise InputError(f"--horizon must be a finite number of seconds > 0, got {self.horizon_s}")
        if not 0.0 < self.confidence < 1.0:
            raise InputError(f"--confidence must lie in (0, 1), got {self.confidence}")
        if self.per_decade < 1:
            raise InputError(f"--per-decade must be >= 1, got {self.per_decade}")
        unknown = [a for a in self.axes if a not in AXES]
        if unknown or not self.axes:
            raise InputError(f"--axis {unknown[0] if unknown else ''!r}: use {', '.join(AXES)}")
        if self.loop_alpha is not None and not 0.0 < self.loop_alpha < 1.0:
            raise InputError(f"--alpha must lie in (0, 1), got {self.loop_alpha}")
        if self.loop_max_steps is not None and self.loop_max_steps < 0:
            raise InputError(f"--max-steps must be >= 0, got {self.loop_max_steps}")

    @property
    def sensors(self) -> tuple[str, ...]:
        """The sensors holding one of :attr:`axes`: the Allan stage analyses all their axes, and only theirs."""
        return tuple(sensor for sensor, names in SENSORS if any(a in self.axes for a in names))

    @property
    def loop_settings(self) -> dict:
        """The loop's settings that differ from its defaults (keyword arguments of the loop)."""
        settings = {"alpha": self.loop_alpha, "max_steps": self.loop_max_steps}
        return {k: v for k, v in settings.items() if v is not None}


@dataclass
class AnalysisResult:
    """What ``analyze`` found, per stage (per-axis dictionaries keyed by axis name): ``static`` (Allan stage),
    ``models`` (fits and selections, without records), ``loops`` (empty without the loop), ``finals`` (final model and
    Kalibr numbers), ``bands`` (the final model's AV range, :class:`~..core.diagnostics.av_band.ModelAvRange`),
    ``overbounds``, ``levels`` (the record's passband level in each final model's band, or None where it holds too
    few bins: :func:`~..core.estimation.readouts.passband.passband_level`, what the resolution judges N by),
    ``warnings``; ``numbers`` (what users paste)"""

    static: StaticAnalysis
    models: dict[str, AxisModel] = field(default_factory=dict)
    loops: dict[str, LoopResult] = field(default_factory=dict)
    finals: dict[str, FinalModel] = field(default_factory=dict)
    bands: dict[str, ModelAvRange] = field(default_factory=dict)
    overbounds: dict[str, AxisOverbound] = field(default_factory=dict)
    levels: dict[str, PassbandLevel | None] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    @property
    def fits(self) -> dict:
        """The model stage's fit of every axis."""
        return {axis: m.fit for axis, m in self.models.items()}

    @cached_property
    def numbers(self) -> PastedNumbers:
        """The numbers to paste (:func:`.numbers.pasted_numbers`), built once from the stages' results when first
        read, after the last stage: every writer renders these."""
        return pasted_numbers(self.static, self.finals, self.overbounds)


def _imu_loop(imu: ImuSeries, temperature: ScalarSeries | None, options: AnalyzeOptions,
              warnings: list[str]) -> ImuLoop:
    """The loop over the recording; without the temperature (and a warning saying why) if it is unusable."""
    try:
        return ImuLoop(imu, temperature, intervals=True, **options.loop_settings)
    except InputError as exc:
        warnings.append(f"closed loop without temperature: {exc}")
        return ImuLoop(imu, None, intervals=True, **options.loop_settings)


def analyze(imu: ImuSeries | MappedImu, temperature: ScalarSeries | None = None, options: AnalyzeOptions | None = None,
            *, progress: Progress | None = None, on_axis: OnAxis | None = None) -> AnalysisResult:
    """Run the stages of the module docstring on a static recording.

    Parameters
    ----------
    imu
        The six axes (rad/s, m/s²), repaired (the reader's notes in ``imu.notes``); or a recording already in files
        (:class:`.mapped.MappedImu`), which this process and its workers then read without a private copy.
    temperature
        The sensor temperature, if any (enables the loop's TEMP test).
    options
        What to compute.
    progress, on_axis
        Called as ``progress(done, total)`` during the Allan stage; as each axis is done.

    Raises
    ------
    InputError
        Input a user can fix (too short, not static, constant axis, …), the message saying what to do.
    """
    options = options or AnalyzeOptions()
    recording = imu if isinstance(imu, MappedImu) else None
    if recording is not None:
        imu = recording.open()
    if options.span is not None:
        imu, recording = imu.between(*options.span), None
    static = analyze_static(imu, kinds=options.kinds, per_decade=options.per_decade, confidence=options.confidence,
                            allow_motion=options.allow_motion, progress=progress, sensors=options.sensors,
                            origin_s=options.span[0] if options.span is not None else 0.0)
    result = AnalysisResult(static)
    if options.finals and len(options.sensors) < len(SENSORS):
        result.warnings.append(f"only the {' and '.join(options.sensors)} analysed (--axis): no filter exports, which "
                               "need both sensors' numbers")
    check_horizon(static, options.horizon_s)
    if options.models.enabled:
        options.models.check_rate(static.dt)
        _model_stages(imu, temperature, options, result, on_axis, recording=recording)
    if not options.finals:
        return result
    result.overbounds = overbounds(static, result.finals, options.horizon_s)
    for axis, final in result.finals.items():
        resolution = resolve_axis(final, result.loops.get(axis), static, axis, result.levels[axis],
                                  horizon_s=options.horizon_s)
        if resolution is not None:
            result.finals[axis], result.overbounds[axis], warning = resolution
            result.warnings.append(warning)
    return result


def _model_stages(imu: ImuSeries, temperature: ScalarSeries | None, options: AnalyzeOptions, result: AnalysisResult,
                  on_axis: OnAxis | None, *, recording: MappedImu | None = None) -> None:
    """Stages 2–5 of the module docstring, into ``result``: each axis by :func:`_axis_stages`, in worker processes
    when ``options.jobs`` asks for them (reading ``recording``'s files when given, ``imu`` mapped from them), the
    results taken in axis order."""
    static = result.static
    loop = _imu_loop(imu, temperature, options, result.warnings) if options.loop else None
    context = _AxisContext(imu, loop, options, static)
    for axis, outcome in _each_axis(context, worker_processes(options.jobs, static.n, len(options.axes)), recording):
        result.warnings += [w for w in outcome.warnings if w not in result.warnings]
        if outcome.loop is not None:
            result.loops[axis] = outcome.loop
        if outcome.final is not None:
            result.finals[axis] = outcome.final
            result.bands[axis] = outcome.band
            result.levels[axis] = outcome.level
        if on_axis is not None:
            on_axis(axis, outcome.model.fit, outcome.loop)
        result.models[axis] = outcome.model.without_data()


@dataclass(frozen=True)
class _AxisContext:
    """What every axis's stages read: the recording, the loop over it (or None), the options, the Allan stage."""

    imu: ImuSeries
    loop: ImuLoop | None
    options: AnalyzeOptions
    static: StaticAnalysis


@dataclass(frozen=True)
class _AxisOutcome:
    """Stages 2–5 of one axis: the model stage (with its record), the loop (or None), the final model, the
    AV range at the Allan stage's τ (both None without stages 4–7), the warnings and the record's passband level in
    the final model's band (:attr:`AnalysisResult.levels`; read here, where the worker holds the record)."""

    model: AxisModel
    loop: LoopResult | None
    final: FinalModel | None
    band: ModelAvRange | None
    warnings: list[str]
    level: PassbandLevel | None = None


def _axis_stages(context: _AxisContext, axis: str) -> _AxisOutcome:
    """Model stage, closed loop, final model and its AV range of one axis (stages 2–5)."""
    static, options, loop = context.static, context.options, context.loop
    index = list(static.axes).index(axis)
    column = static.allan.column(index)
    # with the loop, a winner found on the composite likelihood is finished (exact fit, intervals) only if the loop
    # keeps it: the loop's final fit gets its own
    model = fit_axis(context.imu, axis, options.models, static.dt, column, finish=loop is None)
    fit = model.fit
    warnings = [] if model.note is None else [f"{axis}: {model.note}"]
    loop_result = None
    if loop is not None and fit.estimator != "em":
        warnings.append(f"{axis}: closed loop skipped: it diagnoses the EM's one-step innovations, and this axis was "
                        "fitted by the GMWM (its J-test and per-scale residuals are in model.yaml)")
    elif loop is not None:
        try:
            loop_result = loop.run(axis, fit)
        except InputError as exc:
            warnings.append(f"closed loop skipped: {exc}")
    if model.gmwm_selection is not None and model.fit is model.gmwm:
        warnings += [f"{axis}: {why}" for why in model.gmwm_selection.lines_left_out()]
    if loop_result is None or len(loop_result.steps) == 1:
        model = finish_axis(model, context.imu, axis, options.models, static.dt, allan=column)
        fit = model.fit
    if not options.finals:
        return _AxisOutcome(model, loop_result.without_data() if loop_result is not None else None, None, None,
                            warnings)
    final = final_model(fit, loop_result, column, model.selection)
    if final.fit.short_of_maximum is not None:
        warnings.append(f"{axis}: the final fit is {final.fit.short_of_maximum:.3g} below a log-likelihood its "
                        "intervals' search met: its values and intervals are not the maximum's")
    if final.fit.budget_stop is not None:
        warnings.append(f"{axis}: {final.fit.budget_stop_text()}")
    if final.fit.beyond_budget:
        cut = ", ".join(f"{lab} ({how})" for lab, how in final.fit.beyond_budget.items())
        warnings.append(f"{axis}: the final fit's profile intervals stopped at their budget "
                        f"({PROFILE_BUDGET:.0e} sample-state evaluations); these got other intervals: {cut}")
    if final.random_walk_above_bound:
        k = final.random_walk.value
        warnings.append(f"{axis}: the final random walk {k:.3g} is {final.random_walk_bound.excess(k)}; record "
                        "longer before trusting K")
    band = model_av_range(list(final.fit.components), static.allan.m, static.n, static.dt)
    level = passband_level(context.imu.axis(axis), static.dt, list(final.fit.components))
    # the loop's fits keep no record past here: sent back from a worker and kept for six axes, a step's samples and
    # regressors took (1 + regressors) × N floats each
    return _AxisOutcome(model, loop_result.without_data() if loop_result is not None else None, final, band, warnings,
                        level)


def worker_processes(asked: int, n: int, axes: int) -> int:
    """Worker processes for ``axes`` axes of ``n`` samples when ``asked`` (:class:`AnalyzeOptions`); 1 = none."""
    if asked == 0:
        return min(len(os.sched_getaffinity(0)), axes) if n >= PARALLEL_MIN_SAMPLES else 1
    return min(asked, axes)


#: The context of a worker process's axes (set once per worker by :func:`_set_worker_context`).
_WORKER_CONTEXT: list[_AxisContext] = []


def _set_worker_context(context: _AxisContext, recording: MappedImu | None) -> None:
    """Install ``context`` in this worker with the recording mapped from ``recording``'s files (not sent), or as sent
    (None); the worker keeps its freed arrays for reuse where that pays (:func:`_keep_freed_memory`)."""
    _keep_freed_memory(context.static.n)
    if recording is None:
        _WORKER_CONTEXT[:] = [context]
        return
    imu = recording.open()
    _WORKER_CONTEXT[:] = [replace(context, imu=imu, loop=context.loop.on(imu) if context.loop is not None else None)]


#: Most samples per axis of a record whose axis work keeps its freed arrays for reuse (a state row of 64 MiB).
REUSE_MAX_SAMPLES = 2**23


def _keep_freed_memory(n: int) -> None:
    """:func:`.heap.keep_freed_memory` in this process for a record of ``n`` samples per axis up to
    :data:`REUSE_MAX_SAMPLES`: beyond it the loop searches on statistics of fixed size and its few exact passes gain
    little, while blocks of a state row and more leave holes the process tree's peak memory pays for (docs/em.md,
    "Freed arrays reused, not mapped afresh")."""
    if n <= REUSE_MAX_SAMPLES:
        heap.keep_freed_memory()


def _worker_axis(axis: str) -> _AxisOutcome:
    return _released(_WORKER_CONTEXT[0], axis)


def _released(context: _AxisContext, axis: str) -> _AxisOutcome:
    """:func:`_axis_stages`, then the memory its temporaries freed handed back (:func:`.heap.release_freed_memory`)."""
    try:
        return _axis_stages(context, axis)
    finally:
        heap.release_freed_memory()


def _each_axis(context: _AxisContext, jobs: int,
               recording: MappedImu | None = None) -> Iterator[tuple[str, _AxisOutcome]]:
    """(axis, its outcome) in axis order, here or from ``jobs`` "spawn" worker processes (the context sent to each
    once, the recording's arrays mapped from ``recording``'s files, or from files written into a temporary folder
    removed afterwards, or sent with it where they cannot be written); the workers stop after the last axis or the first
    error (an axis's InputError raised here). Each process doing axis work keeps its freed arrays for reuse and hands
    them back after each axis (:mod:`...heap`; why: docs/em.md, "Freed arrays reused, not mapped afresh")."""
    axes = [a for a in context.static.axes if a in context.options.axes]
    if jobs <= 1:
        _keep_freed_memory(context.static.n)
        for axis in axes:
            yield axis, _released(context, axis)
        return
    with contextlib.ExitStack() as stack:
        if recording is None:
            with contextlib.suppress(OSError):  # no room for the files: each worker gets a copy, as before
                recording = MappedImu.write(context.imu, Path(stack.enter_context(
                    tempfile.TemporaryDirectory(prefix="imu_noise_id_"))))
        sent = context if recording is None else replace(
            context, imu=recording.series, loop=context.loop.on(recording.series) if context.loop is not None else None)
        pool = stack.enter_context(multiprocessing.get_context("spawn").Pool(
            jobs, initializer=_set_worker_context, initargs=(sent, recording)))
        yield from zip(axes, pool.imap(_worker_axis, axes), strict=True)


__all__ = ["AUTO", "DEFAULT_HORIZON_S", "AnalysisResult", "AnalyzeOptions", "AxisOverbound", "FinalModel",
           "MappedImu", "ModelStage", "StaticAnalysis", "analyze", "worker_processes"]
