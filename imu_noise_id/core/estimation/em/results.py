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
    """Record length per parameter for a target precision: ``needed_s[label]`` [s] where 1.96·se (log space) reaches
    ``target``, assuming se ∝ 1/√T; ``reliable[label]`` False for GM parameters with T < 20·τ (a lower bound there)."""

    target: float
    level: str
    current_s: float
    needed_s: dict[str, float]
    relative_halfwidth: dict[str, float]
    reliable: dict[str, bool]


@dataclass
class FitResult:
    """Identified model of one axis: continuous-time components and their uncertainty.

    Attributes
    ----------
    model, components : canonical structure name (``WN+GM+RW``); fitted components, continuous-time units (RR included)
    exog_coef : ``bias`` [u], ``ramp`` [u/s] and exog coefficients, each ``{value, se, ci95}``
    se, ci95, ci95_method : per parameter label (``WN.noise_density``, ``GM2.tau`` …), physical units: standard error
        (inf where undetermined), 95 % interval (lower end 0, upper inf where unbounded) and
        ``wald``/``profile``/``gls``
    loglik, aic, bic, n_params : exact maximised ℓ; 2k − 2ℓ; k·ln(n) − 2ℓ; k, all free parameters
    n, dt : observed (non-NaN) samples; sampling period [s]
    n_iter, converged, n_eval : EM iterations of the winning start; finish converged; its likelihood evaluations
    budget_stop : ℓ's rise over the finish's last :data:`.mle.RECENT_EVALUATIONS` when its budget stopped it, else None
    record_length, information_ok : :class:`RecordLengthAdvice`; observed information positive definite
    profile_evaluations, better_loglik, better_start : profile evaluations; a higher ℓ they met and its components
    log_covariance, covariance_labels : log-parameter covariance (inverse information) and its labels
    statespace, record, standardized : fitted state space; (samples, regressors) fitted; standardised innovations
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
        """Label → ``ci95_method`` of the parameters whose profile :data:`.uncertainty.PROFILE_BUDGET` did not allow."""
        return {lab: how for lab, how in self.ci95_method.items() if how.endswith(BUDGET_SPENT)}

    @property
    def not_resolved_from_zero(self) -> list[str]:
        """Labels of the parameters whose 95 % interval holds zero (a scale's lower end 0; a signed ramp's interval
        across it): their relative precision needs no finite record, so the record-length advice leaves them out
        (:class:`RecordLengthAdvice`)."""
        return [lab for lab, (lo, hi) in self.ci95.items() if lo <= 0.0 <= hi]

    @property
    def short_of_maximum(self) -> float | None:
        """``better_loglik − loglik`` when above 1.92 = ½·χ²₁(0.95) (not at the maximum), else None."""
        if self.better_loglik is None or self.better_loglik - self.loglik <= LR_DROP_95:
            return None
        return float(self.better_loglik - self.loglik)

    def budget_stop_text(self) -> str | None:
        """The finish's budget stop in words; None when it converged or stopped otherwise."""
        if self.budget_stop is None:
            return None
        return (f"the exact maximum-likelihood finish stopped at its budget after {self.n_eval} evaluations, the "
                f"log-likelihood still rising by {self.budget_stop:.3g} over the last {RECENT_EVALUATIONS}: the values "
                "and intervals are near the maximum, not at it")

    def without_data(self) -> FitResult:
        """This result without its record (for keeping many); :meth:`standardized_innovations` then raises."""
        return replace(self, record=None, standardized=None)

    def standardized_innovations(self) -> np.ndarray:
        """One-step innovations / √(their variance), NaN where missing (``standardized`` or one filter pass)."""
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
