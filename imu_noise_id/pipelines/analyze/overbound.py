"""The overbound stage of ``analyze``: per axis, the smallest Kalibr WN+RW whose AV covers, at each τ of the Allan grid
from the sampling period to a horizon (default :data:`~..estimation.readouts.overbound.DEFAULT_HORIZON_S`), the
larger of the data's upper confidence bound and the final model's AV (all components), and is not below ``imu.yaml``'s
per-axis N and K (inflation factors ≥ 1). The LP: :mod:`~imu_noise_id.core.estimation.readouts.overbound`."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ...core.errors import InputError
from ...core.estimation.readouts.overbound import DEFAULT_HORIZON_S, WnRwOverbound, overbound_wn_rw
from .final import FinalModel
from .numbers import axis_readings
from .static import StaticAnalysis


@dataclass(frozen=True)
class AxisOverbound:
    """The overbound of one axis and what it is measured against.

    Attributes
    ----------
    bound : the LP's result (N [u/√Hz], K [u/s/√Hz], binding τ, floors reached, mean AV ratio)
    tau_range : the τ [s] of the grid covered (first, last); horizon_s : the range asked for ends here
    covers : what the bound is made of, in words
    reference_noise_density, reference_random_walk, reference_source : imu.yaml's per-axis values the inflation
        factors are relative to, and where they come from
    """

    bound: WnRwOverbound
    tau_range: tuple[float, float]
    horizon_s: float
    covers: str
    reference_noise_density: float
    reference_random_walk: float
    reference_source: str

    @property
    def noise_density(self) -> float:
        return self.bound.noise_density

    @property
    def random_walk(self) -> float:
        return self.bound.random_walk

    @property
    def inflation_noise_density(self) -> float:
        """N / N_reference (≥ 1)."""
        return self.noise_density / self.reference_noise_density if self.reference_noise_density > 0 else math.inf

    @property
    def inflation_random_walk(self) -> float:
        """K / K_reference (≥ 1)."""
        return self.random_walk / self.reference_random_walk if self.reference_random_walk > 0 else math.inf

    def allan_variance(self, tau: np.ndarray, dt: float) -> np.ndarray:
        """The overbound's Allan variance [u²] at ``tau`` (for plots)."""
        return self.bound.allan_variance(tau, dt)


#: :attr:`AxisOverbound.reference_source` of an axis analysed without a model: its N and K are its Allan-slope readings.
ALLAN_SLOPES = "Allan slopes"


def _references(static: StaticAnalysis, axis: str, final: FinalModel | None) -> tuple[float, float, str]:
    """The per-axis N and K imu.yaml pastes (:func:`.numbers.axis_readings`) and where they come from, in words."""
    n, k = axis_readings(static, axis, final)
    if final is None:
        return n.value, k.value, ALLAN_SLOPES
    if final.random_walk.value is None:
        return n.value, k.value, "final model (N), Allan slope (K: the model has no random walk)"
    return n.value, k.value, "final model"


def check_horizon(static: StaticAnalysis, horizon_s: float) -> None:
    """Refuse (InputError) a horizon ``horizon_s`` [s] shorter than the sampling period, before the model stage runs."""
    if not horizon_s >= static.dt:
        raise InputError(f"--horizon {horizon_s:g} s is shorter than the sampling period {static.dt:g} s: give the "
                         "longest time scale your filter must cover (e.g. 100)")


def axis_overbound(static: StaticAnalysis, axis: str, final: FinalModel | None,
                   horizon_s: float = DEFAULT_HORIZON_S) -> AxisOverbound:
    """The overbound of ``axis`` over τ from the sampling period to ``horizon_s`` [s] (module docstring); InputError
    when the horizon is shorter than the sampling period."""
    check_horizon(static, horizon_s)
    allan = static.allan
    j = static.axes.index(axis)
    upper = allan.ci_high[:, j]
    keep = (allan.tau <= horizon_s * (1 + 1e-9)) & np.isfinite(upper) & (upper > 0)
    tau = allan.tau[keep]
    bound = upper[keep]
    covers = f"the data's upper {100 * allan.confidence:g} % Allan bound"
    if final is not None:
        bound = np.maximum(bound, final.fit.theoretical_allan_variance(tau))
        covers += f" and the final model's AV ({final.model})"
    n_ref, k_ref, source = _references(static, axis, final)
    result = overbound_wn_rw(tau, bound, static.dt, floor=(n_ref, k_ref))
    return AxisOverbound(result, (float(tau[0]), float(tau[-1])), horizon_s, covers, n_ref, k_ref, source)


def data_overbound(static: StaticAnalysis, axis: str, horizon_s: float = DEFAULT_HORIZON_S) -> AxisOverbound:
    """The overbound of the data's upper Allan bound alone (no model's AV, no floor but the Allan slopes'), measured
    against itself: what an axis whose final model is not trusted gives as its N and K (:mod:`.resolution`)."""
    bound = axis_overbound(static, axis, None, horizon_s)
    return replace(bound, reference_noise_density=bound.noise_density, reference_random_walk=bound.random_walk,
                   reference_source="this overbound (the final model is unresolved: its values are not given)")


def overbounds(static: StaticAnalysis, finals: dict[str, FinalModel],
               horizon_s: float = DEFAULT_HORIZON_S) -> dict[str, AxisOverbound]:
    """:func:`axis_overbound` of every axis (with its final model where there is one)."""
    return {axis: axis_overbound(static, axis, finals.get(axis), horizon_s) for axis in static.axes}
