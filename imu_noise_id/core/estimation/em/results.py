"""What a fit returns: the fitted components with their uncertainty, and the recording-length advice."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ... import kalman
from ...errors import InputError
from ...kalman.statespace import StateSpace
from ...noise.components import Component, total_allan_variance
from .mle import LR_DROP_95, RECENT_EVALUATIONS

#: The end of a ``ci95_method`` given where the profile budget was spent (:mod:`.uncertainty`).
BUDGET_SPENT = "profile budget spent"


@dataclass
class RecordLengthAdvice:
    """Recording length needed per parameter for a target relative precision: ``needed_s[label]`` [s] where 1.96·se (log
    space) shrinks to ``target``, assuming se ∝ 1/√T; ``reliable[label]`` False for GM parameters with T < 20·τ_c (they
    improve more slowly: the figure is a lower bound)."""

    target: float
    level: str
    current_s: float
    needed_s: dict[str, float]
    relative_halfwidth: dict[str, float]
    reliable: dict[str, bool]


@dataclass
class FitResult:
    """Identified model of one axis (continuous-time components and their uncertainty).

    Attributes
    ----------
    model : str — canonical structure name (``modelspec.model_name``), e.g. ``WN+GM+RW``
    components : list[Component] — fitted components, continuous-time units (RR's slope included with RR)
    exog_coef : dict[str, dict] — ``bias`` [u], ``ramp`` [u/s], the exog coefficients; each ``{value, se, ci95}``
    se, ci95 : dict[str, ...] — standard error (inverse information; inf where undetermined) and 95 % interval of every
        component parameter, keyed ``WN.noise_density``, ``GM2.tau`` …, physical units; Wald in log space or profile
        likelihood (:mod:`.uncertainty`; lower end 0, upper inf where the data do not bound them)
    ci95_method : dict[str, str] — ``wald``, ``profile`` or ``gls`` (a mean parameter's GLS interval)
    loglik, aic, bic : float — exact maximised ℓ; AIC = 2k − 2ℓ, BIC = k·ln(n) − 2ℓ, k all free parameters
    n, dt : int, float — observed (non-NaN) samples; sampling period [s]
    n_iter, converged — EM iterations of the winning start; whether the quasi-Newton finish converged
    n_eval, budget_stop — the finish's exact likelihood evaluations; when its budget stopped it
        (:data:`.search.FINISH_BUDGET`), how much ℓ rose over its last :data:`.mle.RECENT_EVALUATIONS` (the values are
        short of the maximum by about that much or more), else None
    record_length : RecordLengthAdvice | None — how long to record for the target precision
    information_ok : bool — whether the observed information was positive definite
    profile_evaluations : int — log-likelihood evaluations of the profile intervals
    better_loglik, better_start — a higher log-likelihood the profile search met and its components, else None
    log_covariance, covariance_labels — log-parameter covariance (inverse observed information) and labels
    statespace, record — the fitted state-space model and the (samples, regressors) it was fitted to
    standardized — the record's one-step innovations / √(their variance) at the fit, as the fit's last filter pass
        gave them (None: computed when asked, :meth:`standardized_innovations`)
    """

    model: str
    components: list[Component]
    exog_coef: dict[str, dict]
    se: dict[str, float]
    ci95: dict[str, tuple[float, float]]
    loglik: float
    aic: float
    bic: float
    n: int
    dt: float
    n_iter: int
    converged: bool
    record_length: RecordLengthAdvice | None = None
    information_ok: bool = True
    ci95_method: dict[str, str] = field(default_factory=dict)
    profile_evaluations: int = 0
    better_loglik: float | None = None
    better_start: list[Component] | None = field(default=None, repr=False)
    n_eval: int = 0
    n_params: int = 0
    starts: list[float] = field(default_factory=list)
    log_covariance: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)), repr=False)
    covariance_labels: tuple[str, ...] = ()
    statespace: StateSpace | None = field(default=None, repr=False)
    record: tuple[np.ndarray, np.ndarray] | None = field(default=None, repr=False)
    standardized: np.ndarray | None = field(default=None, repr=False)
    #: Which estimator produced the numbers: ``em`` (maximum likelihood) or ``gmwm`` (:mod:`.gmwm`).
    estimator: str = "em"
    budget_stop: float | None = None

    @property
    def beyond_budget(self) -> dict[str, str]:
        """The parameters whose profile interval the budget did not allow (:data:`.uncertainty.PROFILE_BUDGET`),
        with the method of the interval they got instead (label → ``ci95_method``)."""
        return {lab: how for lab, how in self.ci95_method.items() if how.endswith(BUDGET_SPENT)}

    @property
    def short_of_maximum(self) -> float | None:
        """How far ``loglik`` lies below ``better_loglik`` when by more than ½·χ²₁(0.95) = 1.92 (the fit is not at the
        maximum and its intervals are not the maximum's); None otherwise."""
        if self.better_loglik is None or self.better_loglik - self.loglik <= LR_DROP_95:
            return None
        return float(self.better_loglik - self.loglik)

    def budget_stop_text(self) -> str | None:
        """What a stop of the finish at its evaluation budget means for this fit, in words; None when it converged or
        stopped otherwise."""
        if self.budget_stop is None:
            return None
        return (f"the exact maximum-likelihood finish stopped at its budget after {self.n_eval} evaluations, the "
                f"log-likelihood still rising by {self.budget_stop:.3g} over the last {RECENT_EVALUATIONS}: the values "
                "and intervals are near the maximum, not at it")

    def without_data(self) -> FitResult:
        """This result without the record it was fitted to (samples and regressors, N floats each), for keeping
        many results. :meth:`standardized_innovations` needs the record and raises on the copy."""
        return replace(self, record=None, standardized=None)

    def standardized_innovations(self) -> np.ndarray:
        """One-step innovations / √(their variance), NaN where the sample was missing (a copy of ``standardized``
        when the fit kept them, else one filter pass over the record)."""
        if self.statespace is None or self.record is None:
            raise InputError("this FitResult holds no data to compute innovations from")
        if self.standardized is not None:
            return self.standardized.copy()
        y, z = self.record
        res = kalman.loglik(self.statespace, y, z, profile_mean=False)
        return res.innovations / np.sqrt(res.variances)

    def theoretical_allan_variance(self, tau: np.ndarray) -> np.ndarray:
        """Allan variance [u²] of the fitted components at averaging times tau [s]."""
        return total_allan_variance(self.components, np.asarray(tau, dtype=float), self.dt)
