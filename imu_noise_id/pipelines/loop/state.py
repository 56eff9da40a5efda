"""What the closed loop holds and reports: the model at each step, its diagnosis, the candidates tried."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ...core.deferred import Deferred
from ...core.diagnostics import detectors as det
from ...core.diagnostics.residuals import ResidualErrors
from ...core.diagnostics.spectra import ResidualSpectra
from ...core.diagnostics.whitening import WhiteningFilter
from ...core.estimation.em.results import FitResult
from ...core.noise.components import Component
from ...core.noise.modelspec import structure_name

#: Effects added to the state-space structure / entering as regressors / as data cleaning.
STATE_EFFECTS = ("GM", "RW", "RR", "QN", "OSC", "LPF", "MA", "BI")
EXOG_EFFECTS = ("SIN", "TEMP", "STEP")
CLEANING_EFFECTS = ("OUTLIERS",)


@dataclass(frozen=True)
class ExogTerm:
    """A deterministic regressor of the measurement equation: ``effect`` ``SIN``, ``TEMP`` or ``STEP``; ``params``
    ``frequency`` [Hz] (SIN), ``index`` (first sample after the shift) and ``time`` [s] (STEP), nothing (TEMP)."""

    effect: str
    params: dict[str, float]

    def columns(self, n: int, dt: float, temperature: np.ndarray | None) -> np.ndarray:
        """The term's (n, k) regressor columns."""
        if self.effect == "SIN":
            arg = 2.0 * math.pi * self.params["frequency"] * dt * np.arange(n)
            return np.column_stack([np.sin(arg), np.cos(arg)])
        if self.effect == "TEMP":
            if temperature is None:
                raise ValueError("TEMP term needs the temperature series")
            return (temperature - np.mean(temperature))[:, None]
        if self.effect == "STEP":
            return (np.arange(n) >= int(self.params["index"])).astype(float)[:, None]
        raise ValueError(f"unknown regressor effect {self.effect!r}")

    def describe(self, coef: np.ndarray) -> dict[str, float]:
        """Fitted values of the term from its coefficients (amplitude/phase, coefficient, size)."""
        if self.effect == "SIN":
            return {"frequency": self.params["frequency"], "amplitude": float(np.hypot(coef[0], coef[1])),
                    "phase": float(math.atan2(coef[1], coef[0]))}
        if self.effect == "TEMP":
            return {"coefficient": float(coef[0])}
        return {"index": self.params["index"], "time": self.params["time"], "size": float(coef[0])}


@dataclass
class LoopState:
    """What the model holds at one step: stochastic structure, regressors, removed samples."""

    structure: list[str]
    exog_terms: list[ExogTerm] = field(default_factory=list)
    flagged: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    imputed: np.ndarray = field(default_factory=lambda: np.zeros(0))
    init: list[Component] | None = None

    def with_components(self, components: list[Component]) -> LoopState:
        """This state's regressors and removed samples (copied) with ``components`` as structure and fit start."""
        return LoopState(structure=[c.name for c in components], exog_terms=list(self.exog_terms),
                         flagged=self.flagged.copy(), imputed=self.imputed.copy(), init=list(components))

    def name(self) -> str:
        names = list(self.structure) + [t.effect for t in self.exog_terms]
        if self.flagged.size:
            names.append("OUTLIERS")
        return structure_name(names)


@dataclass
class Diagnosis:
    """A fit with its residuals, error measures and detector findings. ``detected`` runs the detectors on first use
    of :attr:`findings`, ``residual_spectra`` on first use of :attr:`spectra`: the loop judges a candidate by its BIC,
    AV and targeted statistic alone, so a refused candidate's residuals never go through every detector."""

    fit: FitResult
    errors: ResidualErrors
    detected: Deferred[list[det.Finding]]
    innovations: np.ndarray
    tau: np.ndarray
    av_data: np.ndarray
    av_ci: tuple[np.ndarray, np.ndarray]
    av_model: np.ndarray
    exog_values: dict[str, dict[str, float]]
    whitening: WhiteningFilter
    residual_spectra: Deferred[ResidualSpectra]

    @property
    def spectra(self) -> ResidualSpectra:
        """The innovations' spectra for the report (computed once, :attr:`residual_spectra`)."""
        return self.residual_spectra()

    @property
    def findings(self) -> list[det.Finding]:
        """Every detector's finding on the innovations (computed once, :attr:`detected`)."""
        return self.detected()

    @property
    def innovation_variance(self) -> float:
        """The fit's steady-state innovation variance S [u²] (its whitening filter's)."""
        return self.whitening.innovation_variance


@dataclass
class Trial:
    """A candidate effect tried at one step and why it was kept or not. ``partly``: kept for a broad line it
    explains in part (:func:`~imu_noise_id.pipelines.loop.trials.partly_explained`)."""

    finding: det.Finding
    model: str
    bic: float | None
    accepted: bool
    reason: str
    partly: bool = False


@dataclass
class LoopStep:
    """An accepted loop step (0: the start); ``dropped``: what re-selection then removed (a swap: ``"RW (for BI)"``)."""

    index: int
    model: str
    added: str | None
    evidence: str | None
    finding: det.Finding | None
    state: LoopState
    diagnosis: Diagnosis
    trials: list[Trial]
    dropped: tuple[str, ...] = ()

    @property
    def errors(self) -> ResidualErrors:
        return self.diagnosis.errors


@dataclass
class LoopResult:
    """The loop on one axis: its steps, the final verdict and what remains unexplained. ``finish_gain``: how far
    the exact likelihood's maximum lay above the final model's composite-likelihood fit, ℓ's rise in the exact finish
    (0 when it gained nothing; None without a finish: a record fitted exactly, or no step added)."""

    axis: str | None
    dt: float
    n: int
    steps: list[LoopStep]
    passed: bool
    verdict: str
    remaining: list[det.Finding]
    av_inside_band: bool = False
    max_rel_av_error: float = float("nan")
    note: str = ""
    finish_gain: float | None = None

    @property
    def final(self) -> LoopStep:
        return self.steps[-1]

    def without_data(self) -> LoopResult:
        """This result with each step's fit holding no record (:meth:`FitResult.without_data`, (1 + regressors) × N
        floats per step), for keeping or sending a finished loop; the innovations, AVs and findings stay."""
        steps = [replace(s, diagnosis=replace(s.diagnosis, fit=s.diagnosis.fit.without_data())) for s in self.steps]
        return replace(self, steps=steps)
