"""The closed identification loop: fit → diagnose the residuals → add the missing effect → refit → compare.

Per axis (:func:`run_closed_loop`): fit the start (paper 000 section 3's constrained EM, or the model selection's fit)
and diagnose it (:class:`Diagnosis`); refit with each of the ``max_candidates`` most significant findings' effects
added; keep the lowest BIC among those that lower it, do no harm to the AV and remove their evidence (:mod:`.rules`,
:mod:`.trials`); re-select (:mod:`.reselection`); repeat until a verdict or ``max_steps`` effects. GM, RW, RR, QN, OSC,
LPF, MA, BI join the state space; SIN, TEMP, STEP are regressors (``exog``); OUTLIERS are imputed with ŷ_t = y_t − ν_t
(adding −½ ln(2πS_t) to ℓ) or set missing (adding −½ ln(2πS), S steady-state), each one BIC parameter, as is each
searched location. AV band: :func:`~imu_noise_id.core.diagnostics.av_band.model_av_band`, τ ≤ record/10. Beyond the
papers: line groups, clusters, swaps, joint search (docs/loop.md, "The loop's rules").
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
