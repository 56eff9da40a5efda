"""What a fit returns: the fitted components with their uncertainty, and the recording-length advice."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .. import kalman
from ..errors import InputError
from ..kalman.statespace import StateSpace
from ..noise.components import Component, total_allan_variance
from .mle import LR_DROP_95

#: The end of a ``ci95_method`` given where the profile budget was spent (:mod:`.uncertainty`).
BUDGET_SPENT = "profile budget spent"


@dataclass
class RecordLengthAdvice:
    """Recording length needed per parameter for a target relative precision.

    ``needed_s[label]`` is the duration [s] for which the 95 % half-width of the parameter's interval
    (1.96·se in log space, i.e. relative) shrinks to ``target``, assuming se ∝ 1/√T (per-sample information =
    observed information / N). ``reliable[label]`` is False where that scaling is doubtful: GM parameters whose
    correlation time is not ≪ the record (T < 20·τ_c); such parameters improve more slowly than 1/√T until the
    record is many correlation times long, so the figure is a lower bound.
    """

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
    model : str
        Canonical structure name (``modelspec.model_name``), e.g. ``WN+GM+RW``.
    components : list[Component]
        Fitted components, continuous-time units (RR's slope included when the structure has RR).
    exog_coef : dict[str, dict]
        Mean parameters: ``bias`` [u], ``ramp`` slope [u/s] when RR is a regressor, the caller's exog
        coefficients; each ``{value, se, ci95}``.
    se, ci95 : dict[str, ...]
        Standard error and 95 % interval of every component parameter, keyed ``WN.noise_density``, ``GM2.tau`` …,
        physical units. Intervals of positive parameters are exp(log-value ± 1.96·se_log) (asymmetric, Wald)
        where the observed information can be trusted, else profile-likelihood intervals (the other parameters
        re-maximised at every point; lower end 0 when the data cannot exclude 0, upper end inf when they do not
        bound it): see :mod:`.uncertainty`. ``se`` is always the inverse-information one (inf where the
        information does not determine the parameter).
    ci95_method : dict[str, str]
        How each interval was obtained: ``wald``, ``profile`` (profile likelihood) or ``gls`` (a mean parameter's
        GLS interval given the noise parameters).
    loglik, aic, bic : float
        Exact maximised log-likelihood; AIC = 2k − 2ℓ, BIC = k·ln(n) − 2ℓ with k = all free parameters.
    n : int
        Number of observed (non-NaN) samples.
    dt : float
        Sampling period [s].
    n_iter : int
        EM iterations of the winning start (the quasi-Newton evaluations are in ``n_eval``).
    converged : bool
        Whether the quasi-Newton finish reported convergence.
    record_length : RecordLengthAdvice | None
        How long to record for the target precision (when the uncertainty was computed).
    information_ok : bool
        Whether the observed information was positive definite (else some se are inf: not identified).
    profile_evaluations : int
        Log-likelihood evaluations the profile intervals took (0 when every interval is Wald).
    better_loglik, better_start
        A log-likelihood above ``loglik`` the profile search met (the fit missed the maximum) and the components
        there, else None; :meth:`~.model.NoiseModel.fit` then searches again from them.
    log_covariance, covariance_labels
        Covariance of the log-parameters (inverse observed information) and their labels (``WN.noise_density`` …),
        for intervals of derived quantities by the delta method (empty until the uncertainty is computed).
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
    #: Which estimator produced the numbers: ``em`` (maximum likelihood) or ``gmwm`` (:mod:`.gmwm`).
    estimator: str = "em"

    @property
    def beyond_budget(self) -> dict[str, str]:
        """The parameters whose profile interval the budget did not allow (:data:`.uncertainty.PROFILE_BUDGET`),
        with the method of the interval they got instead (label → ``ci95_method``)."""
        return {lab: how for lab, how in self.ci95_method.items() if how.endswith(BUDGET_SPENT)}

    @property
    def short_of_maximum(self) -> float | None:
        """How far ``loglik`` lies below the higher log-likelihood the profile search of the intervals met
        (``better_loglik``), when by more than the 95 % likelihood-ratio threshold (½·χ²₁(0.95) = 1.92): the fit is
        not at the maximum and its intervals, computed around it, are not the maximum's. None otherwise."""
        if self.better_loglik is None or self.better_loglik - self.loglik <= LR_DROP_95:
            return None
        return float(self.better_loglik - self.loglik)

    def without_data(self) -> FitResult:
        """This result without the record it was fitted to (samples and regressors, N floats each), for keeping
        many results. :meth:`standardized_innovations` needs the record and raises on the copy."""
        return replace(self, record=None)

    def standardized_innovations(self) -> np.ndarray:
        """One-step innovations / √(their variance), NaN where the sample was missing."""
        if self.statespace is None or self.record is None:
            raise InputError("this FitResult holds no data to compute innovations from")
        y, z = self.record
        res = kalman.loglik(self.statespace, y, z, profile_mean=False)
        return res.innovations / np.sqrt(res.variances)

    def theoretical_allan_variance(self, tau: np.ndarray) -> np.ndarray:
        """Allan variance [u²] of the fitted components at averaging times tau [s]."""
        return total_allan_variance(self.components, np.asarray(tau, dtype=float), self.dt)
