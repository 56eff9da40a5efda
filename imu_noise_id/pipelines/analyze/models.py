"""The model stage: one error model per axis by maximum likelihood (paper 000's constrained EM and beyond).

``model = "auto"`` ranks the candidate structures by BIC (:func:`~imu_noise_id.core.estimation.selection.
select_model`); a structure such as ``"WN+GM+RW"`` is fitted as given (:class:`~imu_noise_id.core.estimation.model.
NoiseModel`). ``analyze`` and ``fit`` both run this stage.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from ...core.allan import AllanResult
from ...core.axes import ImuSeries
from ...core.errors import InputError
from ...core.estimation.model import FitOptions, NoiseModel
from ...core.estimation.results import FitResult
from ...core.estimation.selection import SelectionResult, select_model
from ...core.noise.modelspec import parse_structure

#: ``model`` values that are not a structure.
AUTO, NONE = "auto", "none"


@dataclass
class AxisModel:
    """The model stage's result for one axis: the fit (with its record while the axis is being processed) and, with
    ``model = "auto"``, the selection it won."""

    fit: FitResult
    selection: SelectionResult | None = None

    def without_data(self) -> AxisModel:
        """The same without the record (kept results stay small whatever the record length)."""
        return AxisModel(self.fit.without_data(), self.selection.without_data() if self.selection else None)


@dataclass
class ModelStage:
    """What the model stage was asked to do."""

    model: str = AUTO
    options: FitOptions = field(default_factory=FitOptions)
    drift: str | None = "em"

    def __post_init__(self) -> None:
        if self.model not in (AUTO, NONE):
            parse_structure(self.model)  # a bad spec is refused before any data is read or fitted

    @property
    def enabled(self) -> bool:
        return self.model != NONE


def fit_axis(imu: ImuSeries, axis: str, stage: ModelStage, dt: float, allan: AllanResult | None = None) -> AxisModel:
    """Select or fit the model of one axis (InputError names the axis); ``allan``: the axis's Allan variance
    when the caller has it (the starting values are fitted to it)."""
    y = imu.axis(axis)
    try:
        if stage.model == AUTO:
            sel = select_model(y, dt, drift=stage.drift, options=stage.options, allan=allan)
            return AxisModel(sel.best, sel)
        detrended = "RR" in parse_structure(stage.model)  # its starting values need the detrended record's AV
        model = NoiseModel(y, dt, stage.model, drift=stage.drift, allan=None if detrended else allan)
        return AxisModel(model.fit(options=stage.options))
    except InputError as exc:
        raise InputError(f"{axis}: {exc}") from None


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
