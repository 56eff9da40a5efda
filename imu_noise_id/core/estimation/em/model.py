"""The noise model of one axis: a component structure on one record (as statsmodels' ``MLEModel``), giving its state
space (paper 000 eqs. 4–9), exact log-likelihood with GLS means, Allan/Whittle starts (§3.5(i)) and fit (EM then
quasi-Newton, :mod:`.search`). Drift with RR (§3.5(iii)): ``'em'`` estimates the slope jointly (regressor t·dt),
``'ls'`` removes a least-squares line first and re-estimates bias and slope by GLS with the fitted noise model."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ... import kalman
from ...allan import AllanResult
from ...errors import InputError
from ...kalman import harmonic
from ...kalman import statespace as ss
from ...noise.components import COMPONENT_TYPES, Component
from ...noise.digital import SensorFilter
from ...noise.modelspec import parse_model, parse_structure
from ...quality import interpolate_missing
from . import mle, starts, whittle
from .results import FitResult
from .search import FINISH_BUDGET, fit_noise_model

#: Smallest number of observed samples accepted, and per free parameter.
MIN_SAMPLES, MIN_SAMPLES_PER_PARAMETER = 100, 20
#: Regressor names the model uses itself.
RESERVED_REGRESSORS = ("bias", "ramp")


@dataclass(frozen=True)
class FitOptions:
    """How :meth:`NoiseModel.fit` searches and what it reports.

    Attributes
    ----------
    n_starts : distinct starting values tried (best likelihood kept)
    em_iter, em_tol : EM iterations before the quasi-Newton finish; the §3.5(ii) threshold
    polish : finish by L-BFGS-B on the exact likelihood (``False`` with a large ``em_iter``: the paper's pure EM)
    spectral_init : Whittle-refined starts and Whittle-preconditioned finish (beyond the paper)
    uncertainty : compute information, standard errors, intervals and record-length advice
    target_precision : relative 95 % half-width of the record-length advice (0.10 = ±10 %)
    finish_budget : sample-state evaluations of one start's finish (:func:`.search.finish_evaluations`); None: no
        bound
    stop_stalled : the finish also stops once the log-likelihood stalls (:func:`.mle.maximise`): for a refit from a
        start already close to the maximum
    """

    n_starts: int = 3
    em_iter: int = 3
    em_tol: float = 1e-9
    polish: bool = True
    spectral_init: bool = True
    uncertainty: bool = True
    target_precision: float = 0.10
    finish_budget: float | None = FINISH_BUDGET
    stop_stalled: bool = False

    def __post_init__(self) -> None:
        if not 0 < self.target_precision < 1:
            raise InputError(f"target_precision must be in (0, 1), got {self.target_precision}")
        if self.n_starts < 1 or self.em_iter < 0:
            raise InputError(f"n_starts must be >= 1 and em_iter >= 0, got {self.n_starts}, {self.em_iter}")


def check_signal(y: np.ndarray, dt: float) -> np.ndarray:
    """``y`` as a float array after the input checks (InputError on bad dt, not 1-D, inf, too few, constant)."""
    if not (isinstance(dt, (int, float, np.floating)) and math.isfinite(dt) and dt > 0):
        raise InputError(f"sampling period dt must be a finite number > 0 s, got {dt!r}")
    y = np.asarray(y, dtype=float)
    if y.ndim != 1:
        raise InputError(f"the signal must be one axis (1-D), got shape {y.shape}")
    if np.any(np.isinf(y)):
        raise InputError("the signal contains infinite values; remove them or mark them as NaN (missing)")
    obs = np.isfinite(y)
    if not np.any(obs):
        raise InputError("the signal has no valid samples (all NaN)")
    if int(obs.sum()) < MIN_SAMPLES:
        raise InputError(f"the signal has {int(obs.sum())} valid samples; at least {MIN_SAMPLES} are needed")
    if np.ptp(y[obs]) == 0.0:
        raise InputError("the signal is constant: there is no noise to identify (sensor stuck or wrong topic?)")
    return y


def parse_structure_or_components(structure: str | list[Component]) -> tuple[list[str], list[Component] | None]:
    """Component names and, when values are given (``'WN(2e-4)+RW(3e-6)'`` or Component objects), the components."""
    if isinstance(structure, str):
        if "(" in structure:
            comps = parse_model(structure)
            return [c.name for c in comps], comps
        return parse_structure(structure), None
    comps = list(structure)
    if not comps or not all(isinstance(c, Component) for c in comps):
        raise InputError("structure must be a model string such as 'WN+GM+RW' or a list of Component objects")
    return [c.name for c in comps], comps


class NoiseModel:
    """A noise structure on one record; InputError on a bad signal, structure or exog, too few samples per parameter, or
    a filter cutoff not below Nyquist.

    Parameters
    ----------
    y, dt : samples [u] (NaN = missing) at period ``dt`` [s]
    structure : ``'WN+GM+RW+RR'``, a spec with values (``'WN(2e-4)+RW(3e-6)'``, the start) or components
    exog, exog_names : (N, k) finite regressors of y_t = H x_t + B z_t + v_t and their names (B by GLS / in the EM)
    drift : with RR, ``'em'`` (joint) or ``'ls'`` (line removed first); ``None`` forbids RR
    allan, periodogram : the AV (one column) and banded periodogram of :meth:`detrended`, when the caller has them
    starts : further starting values (e.g. the GMWM fit); those not of the structure are ignored
    sensor_filter : the sensor's known digital low-pass: a DLPF starts at its cutoff and order
    """

    def __init__(self, y: np.ndarray, dt: float, structure: str | list[Component], *, exog: np.ndarray | None = None,
                 exog_names: list[str] | tuple[str, ...] | None = None, drift: str | None = "em",
                 allan: AllanResult | None = None, starts: list[list[Component]] | None = None,
                 periodogram: whittle.BandedPeriodogram | None = None,
                 sensor_filter: SensorFilter | None = None) -> None:
        y = check_signal(y, dt)
        if sensor_filter is not None:
            try:
                sensor_filter.check_rate(dt)
            except ValueError as exc:
                raise InputError(str(exc)) from None
        self.sensor_filter = sensor_filter
        names, given = parse_structure_or_components(structure)
        ss.validate_structure(names)
        if given is not None:
            mle.Parameterisation.of(given).to_theta(given)  # positive, finite initial values
        if "RR" in names and drift not in ("em", "ls"):
            raise InputError(f"structure has RR: drift must be 'em' or 'ls', got {drift!r}")
        self.dt = float(dt)
        self.names = names
        self.given = given
        self.n_total = y.size
        self.observed = np.isfinite(y)
        self.n_obs = int(self.observed.sum())
        self.t = self.dt * np.arange(self.n_total)
        self.ls_slope: tuple[float, float] | None = None
        self.fit_names = list(names)
        if "RR" in names and drift == "ls":
            y = self._remove_line(y)
            self.fit_names = [n for n in names if n != "RR"]
            if self.given is not None:
                self.given = [c for c in self.given if c.name != "RR"]
        self.y = y
        self.allan = allan
        self._periodogram = periodogram
        self.extra_starts = [sorted((c for c in start if c.name in self.fit_names),
                                    key=lambda c: self.fit_names.index(c.name)) for start in (starts or [])]
        self.extra_starts = [s for s in self.extra_starts if [c.name for c in s] == self.fit_names]
        self.exog_names, self.z = self._regressors(exog, exog_names)
        self.sinusoid_omega = tuple(harmonic.sinusoid_omega(column) for column in self.z.T)
        self.n_free_noise = sum(len(COMPONENT_TYPES[n].parameter_names) for n in self.fit_names if n != "RR")
        n_params = self.n_free_noise + self.z.shape[1]
        if self.n_obs < MIN_SAMPLES_PER_PARAMETER * n_params:
            raise InputError(
                f"{self.n_obs} valid samples are too few for {n_params} parameters of {'+'.join(names)}; record at "
                f"least {MIN_SAMPLES_PER_PARAMETER * n_params} samples or choose a simpler model"
            )

    def _remove_line(self, y: np.ndarray) -> np.ndarray:
        """Least-squares line removed (paper 000 §3.5(iii)); its slope and OLS standard error kept."""
        obs = self.observed
        A = np.column_stack([np.ones(self.n_obs), self.t[obs]])
        coef, *_ = np.linalg.lstsq(A, y[obs], rcond=None)
        resid = y[obs] - A @ coef
        s2 = float(resid @ resid) / max(self.n_obs - 2, 1)
        cov_ls = s2 * np.linalg.inv(A.T @ A)
        self.ls_slope = (float(coef[1]), math.sqrt(cov_ls[1, 1]))
        return y - coef[1] * self.t

    def _regressors(self, exog: np.ndarray | None, exog_names) -> tuple[tuple[str, ...], np.ndarray]:
        columns = [np.ones(self.n_total)]
        if "RR" in self.fit_names:
            columns.append(self.t)
        names: tuple[str, ...] = ()
        if exog is not None:
            exog = np.asarray(exog, dtype=float)
            if exog.ndim == 1:
                exog = exog[:, None]
            if exog.shape[0] != self.n_total:
                raise InputError(f"exog must have {self.n_total} rows (one per sample), got {exog.shape[0]}")
            names = tuple(exog_names or [f"exog{j}" for j in range(exog.shape[1])])
            if len(names) != exog.shape[1] or len(set(names)) != len(names):
                raise InputError("exog_names must give one distinct name per exog column")
            if set(names) & set(RESERVED_REGRESSORS):
                raise InputError("exog names 'bias' and 'ramp' are reserved")
            columns.extend(exog.T)
        return names, np.asfortranarray(np.column_stack(columns))  # each column contiguous (the filter's inputs)

    # -- the model at given parameters ------------------------------------------------------------------------
    @property
    def parameter_bounds(self) -> dict[str, tuple[float, float]]:
        """Physical ranges searched (:func:`.mle.physical_bounds` of this record)."""
        return mle.physical_bounds(self.n_total, self.dt)

    def statespace(self, components: list[Component]) -> ss.StateSpace:
        """State-space form of ``components`` (fitted structure, RR as a measurement regressor)."""
        return ss.from_components(components, self.dt, ramp="measurement", intercept=True, exog_names=self.exog_names,
                                  sinusoid_omega=self.sinusoid_omega)

    def loglik(self, components: list[Component]) -> float:
        """Exact log-likelihood of ``components`` on the record, mean parameters at their GLS estimate."""
        return float(kalman.loglik(self.statespace(components), self.y, self.z, innovations=False).loglik)

    # -- starting values ------------------------------------------------------------------------------------
    def detrended(self) -> np.ndarray:
        """The gap-filled record, less a least-squares line when the structure has RR (the starts' input)."""
        y_av = interpolate_missing(self.y)
        if "RR" in self.fit_names:
            A = np.column_stack([np.ones(self.n_total), self.t])
            y_av = y_av - A @ np.linalg.lstsq(A, y_av, rcond=None)[0]
        return y_av

    def banded_periodogram(self) -> whittle.BandedPeriodogram:
        """The banded periodogram of :meth:`detrended` (computed once per model, or given)."""
        if self._periodogram is None:
            self._periodogram = whittle.banded_periodogram(self.detrended())
        return self._periodogram

    def starting_values(self, n_starts: int, spectral: bool,
                        periodogram: whittle.BandedPeriodogram | None = None) -> list[list[Component]]:
        """The given components, or up to ``n_starts`` distinct AV-fit starts (Whittle-refined, a DLPF at its best
        order, :func:`.starts.filter_orders`; order 2 without ``spectral``), then the caller's further starts."""
        if self.given is not None:
            return [list(self.given)]
        y_av = self.detrended()
        if self.allan is None:
            self.allan = starts.allan_of(y_av, self.dt)
        bp = periodogram or self.banded_periodogram() if spectral or "OSC" in self.fit_names else None
        n_osc = self.fit_names.count("OSC")
        lines = whittle.osc_start_frequencies(bp, self.dt, n_osc) if n_osc else []
        fits = starts.fit_allan(self.fit_names, self.allan, self.dt, osc_frequencies=lines)
        if spectral:  # a DLPF's order is chosen here, by the Whittle likelihood (:func:`.starts.filter_orders`)
            fits = sorted((whittle.whittle_fit(v, y_av, self.dt, bp, self.parameter_bounds)
                           for _, c in fits for v in starts.filter_orders(c, self.sensor_filter)),
                          key=lambda r: -r[0])
            fits = starts.distinct([(-w, c) for w, c in fits], self.allan.tau, self.dt)
        return [c for _, c in fits[:max(n_starts, 1)]] + [list(c) for c in self.extra_starts]

    def fit(self, init: list[Component] | None = None, options: FitOptions | None = None) -> FitResult:
        """Maximum-likelihood fit (EM then quasi-Newton) from ``init`` or the starting values (:mod:`.search`)."""
        return fit_noise_model(self, init, options or FitOptions())


def fit_model(y: np.ndarray, dt: float, structure: str | list[Component], *, exog: np.ndarray | None = None,
              exog_names: list[str] | None = None, init: list[Component] | None = None, drift: str | None = "em",
              options: FitOptions | None = None) -> FitResult:
    """Fit one structure to one axis: ``NoiseModel(y, dt, structure, …).fit(init, options)``."""
    return NoiseModel(y, dt, structure, exog=exog, exog_names=exog_names, drift=drift).fit(init, options)
