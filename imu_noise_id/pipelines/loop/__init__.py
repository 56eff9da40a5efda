"""The closed identification loop: fit → diagnose the residuals → add the missing effect → refit → compare.

Per axis (:func:`run_closed_loop`): fit the start (the constrained EM of paper 000 section 3, or the model selection's
fit as it is) and diagnose it (:class:`Diagnosis`: BIC, AV misfit, Ljung–Box, detectors of
:mod:`imu_noise_id.core.diagnostics`); refit with each of the ``max_candidates`` most significant findings' effects
added; keep the lowest BIC among those that lower the BIC, do no harm to the AV and remove their evidence
(:mod:`.rules`, :mod:`.trials`); re-select (:mod:`.reselection`); repeat until the verdict "residuals pass", "nothing
more can be added", "nothing improves" or ``max_steps`` effects. GM, RW, RR, QN, OSC, LPF, MA, BI join the state space;
SIN, TEMP, STEP are regressors of the measurement equation (``exog``); OUTLIERS are imputed with the one-step prediction
ŷ_t = y_t − ν_t (``outliers="impute"``: the sample then adds −½ ln(2πS_t) to ℓ, as an additive-outlier dummy would) or
set missing (each counted as −½ ln(2πS), S the steady-state innovation variance, so that ℓ stays comparable across
steps); the BIC counts one parameter per flagged sample and per searched location (a SIN's frequency, a STEP's sample).
The AV band is the estimator's under the null "the fitted model holds"
(:func:`~imu_noise_id.core.diagnostics.av_band.model_av_band`), τ up to a tenth of the record. Beyond the papers: line
groups, resonance clusters, re-selection's swaps and the joint search (rules and reasons: docs/loop.md, "The loop's
rules").
"""

from .run import ImuLoop, align_temperature, run_closed_loop, run_closed_loop_imu
from .state import (
    CLEANING_EFFECTS,
    EXOG_EFFECTS,
    STATE_EFFECTS,
    Diagnosis,
    ExogTerm,
    LoopResult,
    LoopState,
    LoopStep,
    Trial,
)

__all__ = [
    "CLEANING_EFFECTS",
    "EXOG_EFFECTS",
    "STATE_EFFECTS",
    "Diagnosis",
    "ExogTerm",
    "ImuLoop",
    "LoopResult",
    "LoopState",
    "LoopStep",
    "Trial",
    "align_temperature",
    "run_closed_loop",
    "run_closed_loop_imu",
]
