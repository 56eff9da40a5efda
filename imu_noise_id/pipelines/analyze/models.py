"""The model stage of ``analyze`` and ``fit``: one error model per axis by maximum likelihood (paper 000's constrained
EM and beyond), by the GMWM (:mod:`~imu_noise_id.core.estimation.gmwm.fit`), or both.

``model = "auto"`` ranks the candidate structures by BIC (:func:`~..estimation.em.selection.select_model`)
or WIC (:func:`~imu_noise_id.core.estimation.gmwm.select.select_gmwm`); a structure (``"WN+GM+RW"``) is fitted as given.
``estimator``: ``em``; ``gmwm``; ``both`` (the GMWM's fits one more EM start, the EM's fit the model, the two compared
by :mod:`~..estimation.readouts.agreement`); ``auto`` (the EM up to :data:`EM_MAX_SAMPLES` samples per axis, the
GMWM beyond, with a note).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

from ...core.allan import AllanResult
from ...core.axes import ImuSeries
from ...core.errors import InputError
from ...core.estimation.em.model import FitOptions, NoiseModel
from ...core.estimation.em.results import FitResult
from ...core.estimation.em.selection import SelectionResult, finish_winner, select_model
from ...core.estimation.gmwm.fit import GmwmFit, GmwmOptions, fit_gmwm, prepare
from ...core.estimation.gmwm.lines import record_lines
from ...core.estimation.gmwm.select import GmwmSelection, select_gmwm
from ...core.estimation.readouts.agreement import Comparison, compare
from ...core.noise.digital import SensorFilter
from ...core.noise.modelspec import parse_structure

#: ``model`` values that are not a structure.
AUTO, NONE = "auto", "none"
#: ``estimator`` values.
ESTIMATORS = ("auto", "em", "gmwm", "both")
#: Above this many samples per axis ``estimator = "auto"`` uses the GMWM (reasons: docs/gmwm.md, ``estimator``).
EM_MAX_SAMPLES = 4_000_000


@dataclass
class AxisModel:
    """The model stage's result for one axis: the fit (with its record while the axis is being processed) and, with
    ``model = "auto"``, the selection it won; with the GMWM, its fit and WIC selection, and with both estimators
    the comparison. ``note``: why the estimator differs from the one asked for."""

    fit: FitResult
    selection: SelectionResult | None = None
    gmwm: GmwmFit | None = None
    gmwm_selection: GmwmSelection | None = None
    comparison: Comparison | None = None
    note: str | None = None

    def without_data(self) -> AxisModel:
        """The same without the record (kept results stay small whatever the record length)."""
        fit = self.fit.without_data()
        return replace(self, fit=fit, selection=self.selection.without_data() if self.selection else None,
                       gmwm=fit if self.gmwm is self.fit else self.gmwm)


@dataclass
class ModelStage:
    """What the model stage was asked to do: ``model`` (``auto``, ``none`` or a structure), the fit's ``options``,
    the ramp's ``drift``, the ``estimator`` and the GMWM's options, and ``sensor_filter``: what the user knows of the
    sensor's digital low-pass (the EM's starts, :class:`~imu_noise_id.core.estimation.em.model.NoiseModel`)."""

    model: str = AUTO
    options: FitOptions = field(default_factory=FitOptions)
    drift: str | None = "em"
    estimator: str = "auto"
    gmwm: GmwmOptions = field(default_factory=GmwmOptions)
    sensor_filter: SensorFilter | None = None

    def __post_init__(self) -> None:
        if self.model not in (AUTO, NONE):
            parse_structure(self.model)  # a bad spec is refused before any data is read or fitted
        if self.estimator not in ESTIMATORS:
            raise InputError(f"estimator must be one of {', '.join(ESTIMATORS)}, got {self.estimator!r}")

    def check_rate(self, dt: float) -> None:
        """InputError, before any fit, when the sensor filter's cutoff is not below the Nyquist frequency of a record
        at period ``dt`` [s]."""
        if self.sensor_filter is None:
            return
        try:
            self.sensor_filter.check_rate(dt)
        except ValueError as exc:
            raise InputError(f"--sensor-filter: {exc}: give the cutoff the sensor is configured with, or leave the "
                             "option out and let the data show the roll-off") from None

    @property
    def enabled(self) -> bool:
        return self.model != NONE

    def resolve(self, n: int) -> tuple[str, str | None]:
        """The estimator used on an n-sample axis, and the note saying why when ``auto`` chose the GMWM."""
        if self.estimator != "auto":
            return self.estimator, None
        if n > EM_MAX_SAMPLES:
            return "gmwm", (f"{n} samples per axis are beyond what the EM fits on this machine in reasonable time "
                            f"(threshold {EM_MAX_SAMPLES}, docs/gmwm.md): the GMWM was used (--estimator em forces "
                            "the EM)")
        return "em", None


def _gmwm_axis(y, dt: float, stage: ModelStage, allan: AllanResult | None) -> tuple[GmwmFit, GmwmSelection | None]:
    wv, slope = prepare(y, dt, stage.gmwm)
    if stage.model == AUTO:
        sel = select_gmwm(None, dt, options=stage.gmwm, allan=allan, wv=wv, slope=slope,
                          lines=tuple(record_lines(y, dt, slope)))
        return sel.best, sel
    return fit_gmwm(None, dt, stage.model, options=stage.gmwm, wv=wv, slope=slope), None


def fit_axis(imu: ImuSeries, axis: str, stage: ModelStage, dt: float, allan: AllanResult | None = None, *,
             finish: bool = True) -> AxisModel:
    """Select or fit the model of one axis (InputError names the axis); ``allan``: the axis's Allan variance
    when the caller has it (the starting values are fitted to it). ``finish`` False: a selection on the composite
    likelihood leaves its winner there, without intervals (:func:`finish_axis` finishes it), for a caller whose closed
    loop may replace it; not with the GMWM beside it (the two are compared at once)."""
    y = imu.axis(axis)
    try:
        estimator, note = stage.resolve(y.size)
        gm, gm_sel = _gmwm_axis(y, dt, stage, allan) if estimator in ("gmwm", "both") else (None, None)
        if estimator == "gmwm":
            return AxisModel(gm, None, gm, gm_sel, note=note)
        starts = ({k: list(f.components) for k, f in gm_sel.fits.items()} if gm_sel is not None
                  else {stage.model: list(gm.components)} if gm is not None else None)
        if stage.model == AUTO:
            sel = select_model(y, dt, drift=stage.drift, options=stage.options, allan=allan, extra_starts=starts,
                               sensor_filter=stage.sensor_filter, finish=finish or gm is not None)
            em, em_sel = sel.best, sel
        else:
            detrended = "RR" in parse_structure(stage.model)  # its starting values need the detrended record's AV
            model = NoiseModel(y, dt, stage.model, drift=stage.drift, allan=None if detrended else allan,
                               starts=list(starts.values()) if starts else None, sensor_filter=stage.sensor_filter)
            em, em_sel = model.fit(options=stage.options), None
        return AxisModel(em, em_sel, gm, gm_sel, compare(em, gm) if gm is not None else None, note)
    except InputError as exc:
        raise InputError(f"{axis}: {exc}") from None


def finish_axis(model: AxisModel, imu: ImuSeries, axis: str, stage: ModelStage, dt: float, *,
                allan: AllanResult | None = None) -> AxisModel:
    """``model`` (of :func:`fit_axis` with ``finish`` False) with its selection's winner fitted on the exact likelihood
    and given its intervals (:func:`~imu_noise_id.core.estimation.em.selection.finish_winner`); unchanged when there is
    nothing to finish."""
    if model.selection is None or not model.selection.unfinished:
        return model
    structure = model.selection.best_key
    y = imu.axis(axis)
    try:
        noise_model = NoiseModel(y, dt, structure, drift=stage.drift,
                                 allan=None if "RR" in parse_structure(structure) else allan,
                                 sensor_filter=stage.sensor_filter)
        selection = finish_winner(model.selection, noise_model, stage.options)
    except InputError as exc:
        raise InputError(f"{axis}: {exc}") from None
    return replace(model, fit=selection.best, selection=selection)


def fit_axes(imu: ImuSeries, axes: list[str], stage: ModelStage, dt: float,
             on_fit: Callable[[str, FitResult], None] | None = None) -> dict[str, AxisModel]:
    """:func:`fit_axis` on every axis; the records are dropped as soon as each axis is done (``on_fit`` sees the
    fit first)."""
    out = {}
    for axis in axes:
        result = fit_axis(imu, axis, stage, dt)
        if on_fit is not None:
            on_fit(axis, result.fit)
        out[axis] = result.without_data()
    return out
