"""The closed identification loop: fit → diagnose the residuals → add the missing effect → refit → compare.

One axis at a time (:func:`run_closed_loop`):

1. fit the starting structure (a :class:`~imu_noise_id.core.estimation.model.NoiseModel`, the constrained
   EM of paper 000 section 3), or take the fit the caller already has (the model selection's winner), and
   measure its errors (:class:`ResidualErrors`: log-likelihood,
   BIC, AV misfit, Ljung–Box p of the standardised innovations, residual spectral peak ratio); a start holding
   the sensor's first-order low-pass (LPF) tries a second-order one in its place (``reselection.swap_start_filter``);
2. run every detector of :mod:`imu_noise_id.core.diagnostics.detectors` and
   :mod:`~imu_noise_id.core.diagnostics.av_signatures` on the fit's residuals;
3. take the significant findings (the most significant per effect, GM candidates of distinct τ bands apart,
   ranked by p-value), and for the ``max_candidates`` most significant ones add the effect, initialised from
   its detector, and refit;
4. a candidate is *accepted* when the BIC decreases **and** the residual evidence it targeted is gone (its
   statistic, re-measured at the same place, is below its threshold or has halved); of the accepted
   candidates the one with the lowest BIC becomes the next step; a resonance (OSC) for a broad line that lowers
   the BIC but leaves the line's statistic above its threshold and above half brings the strongest resonance
   left beside it, and the pair is judged as one step (a cluster, ``trials.attempt_cluster``); while the model's
   AV is outside the data's band, a broad line's resonance (or pair) that lowers the BIC by 10 or more, the AV
   misfit and the line's statistic is kept as explaining it in part (``trials.partly_explained``);
5. repeat until no detector fires ("residuals pass"), only evidence for effects already in the model remains
   ("nothing more can be added"), no candidate is accepted ("nothing improves"), or ``max_steps`` effects were
   added.

Effects outside the linear-Gaussian state space enter as deterministic regressors in the measurement equation
(``exog`` of the noise model, coefficients estimated with the noise model): ``SIN`` (a sine and a cosine at the
detected frequency), ``TEMP`` (temperature minus its mean), ``STEP`` (a unit step at the detected sample).
``OUTLIERS`` are data cleaning with one additive-outlier dummy per flagged sample: with
``outliers="impute"`` (default) each flagged sample is replaced by the previous fit's one-step prediction
ŷ_t = y_t − ν_t, so that its innovation is (nearly) zero and the filter skips its update, which is what a
dummy whose coefficient absorbs the spike does; the sample then contributes −½ ln(2πS_t) to the likelihood,
as with the dummy. With ``outliers="missing"`` the flagged samples become NaN (the exact missing-sample
treatment, but the estimator's slower engine); each then counts −½ ln(2πS) (S the steady-state innovation
variance) in the reported log-likelihood, so that log-likelihoods stay comparable across steps. Either way the
BIC counts one parameter per flagged sample, and one more per searched location (a SIN's frequency, a STEP's
sample), since the detector picked the best of many.

A refit starts from the previous fit's components plus the new one at the detector's values; when the
likelihood nevertheless drops (a local optimum: nested models cannot lose likelihood) it is refitted with the
line's power shared (a new resonance on a line an existing one carries: both start at σ/√2,
``trials.shared_power_start``) and from the estimator's own starting values, the best kept. ``GM``, ``RW``,
``RR``, ``QN`` are added to the state-space structure.

The Allan variances (data with the fitted regressors removed, against the model's theoretical AV) use
τ = m·dt up to a tenth of the record; their 95 % intervals are those of the estimator under the null hypothesis
"the fitted model holds", with its exact variance for that model
(:func:`~imu_noise_id.core.diagnostics.av_band.model_av_band`), not a power-law EDF read from the noisy data.
The rules that judge one fit against another are in :mod:`.rules`, the moves a step tries in :mod:`.trials`,
re-selection's drops and swaps in :mod:`.reselection`.
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
