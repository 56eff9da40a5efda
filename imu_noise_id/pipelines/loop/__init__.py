"""The closed identification loop: fit → diagnose the residuals → add the missing effect → refit → compare.

Per axis (:func:`run_closed_loop`): fit and diagnose the start (paper 000 section 3's constrained EM, or the model
selection's fit); refit with each of the ``max_candidates`` most significant findings' effects added; keep the lowest
BIC of those that lower it, do no harm to the AV and remove their evidence (:mod:`.rules`, :mod:`.trials`); re-select
(:mod:`.reselection`); repeat until a verdict or ``max_steps`` effects. :data:`STATE_EFFECTS` join the state space,
:data:`EXOG_EFFECTS` are regressors; OUTLIERS are imputed, ŷ_t = y_t − ν_t (−½ ln(2πS_t) in ℓ), or set missing
(−½ ln(2πS) added, S steady-state), each one BIC parameter, as is each searched location. AV band:
:func:`~imu_noise_id.core.diagnostics.av_band.model_av_band`, τ ≤ record/10. Rules beyond the papers: docs/loop.md.
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
