"""The closed identification loop: fit → diagnose the residuals → add the missing effect → refit → compare.

One axis at a time (:func:`run_closed_loop`):

1. fit the starting structure (``fit_model`` of :mod:`imu_noise_id.core.estimation.fit`, the
   constrained EM of paper 000 section 3) and measure its errors (:class:`ResidualErrors`: log-likelihood,
   BIC, AV misfit, Ljung–Box p of the standardised innovations, residual spectral peak ratio);
2. run every detector of :mod:`imu_noise_id.core.diagnostics.detectors` on the fit's residuals;
3. take the significant findings (the most significant per effect, GM candidates of distinct τ bands apart,
   ranked by p-value), and for the ``max_candidates`` most significant ones add the effect, initialised from
   its detector, and refit;
4. a candidate is *accepted* when the BIC decreases **and** the residual evidence it targeted is gone (its
   statistic, re-measured at the same place, is below its threshold or has halved); of the accepted
   candidates the one with the lowest BIC becomes the next step;
5. repeat until no detector fires ("residuals pass"), only evidence for effects already in the model remains
   ("nothing more can be added"), no candidate is accepted ("nothing improves"), or ``max_steps`` effects were
   added.

Effects outside the linear-Gaussian state space enter as deterministic regressors in the measurement equation
(``exog`` of ``fit_model``, coefficients estimated with the noise model): ``SIN`` (a sine and a cosine at the
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
likelihood nevertheless drops (a local optimum: nested models cannot lose likelihood) it is refitted from the
estimator's own starting values. ``GM``, ``RW``, ``RR``, ``QN`` are added to the state-space structure.

The Allan variances (data with the fitted regressors removed, against the model's theoretical AV) use
τ = m·dt up to a tenth of the record, where each estimate has roughly ten or more degrees of freedom; their
95 % intervals take the noise type at each τ from the *model's* AV (the null hypothesis), not from the noisy
data.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..core.allan import allan_variance, choose_m, identify_alpha
from ..core.axes import AXES, ImuSeries, ScalarSeries
from ..core.diagnostics import detectors as det
from ..core.diagnostics.residuals import ResidualErrors, av_misfit_z, line_statistic, residual_errors
from ..core.diagnostics.whitening import WhiteningFilter
from ..core.errors import InputError
from ..core.noise.components import GM, QN, RR, RW, Component, total_allan_variance
from ..core.noise.modelspec import CANONICAL_ORDER, parse_structure, structure_name

#: Effects added to the state-space structure / entering as regressors / as data cleaning.
STATE_EFFECTS = ("GM", "RW", "RR", "QN")
EXOG_EFFECTS = ("SIN", "TEMP", "STEP")
CLEANING_EFFECTS = ("OUTLIERS",)

Fitter = Callable[..., Any]


@dataclass(frozen=True)
class ExogTerm:
    """A deterministic regressor of the measurement equation.

    Attributes
    ----------
    effect : str
        ``SIN``, ``TEMP`` or ``STEP``.
    params : dict
        ``frequency`` [Hz] (SIN) or ``index`` (STEP, first sample after the shift); nothing for TEMP.
    """

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

    def name(self) -> str:
        names = list(self.structure) + [t.effect for t in self.exog_terms]
        if self.flagged.size:
            names.append("OUTLIERS")
        return structure_name(names)


@dataclass
class Diagnosis:
    """A fit with its residuals, error measures and detector findings."""

    fit: Any
    errors: ResidualErrors
    findings: list[det.Finding]
    innovations: np.ndarray
    tau: np.ndarray
    av_data: np.ndarray
    av_ci: tuple[np.ndarray, np.ndarray]
    av_model: np.ndarray
    exog_values: dict[str, dict[str, float]]
    innovation_variance: float


@dataclass
class Trial:
    """A candidate effect tried at one step and why it was kept or not."""

    finding: det.Finding
    model: str
    bic: float | None
    accepted: bool
    reason: str


@dataclass
class LoopStep:
    """One accepted step of the loop (step 0 is the starting model)."""

    index: int
    model: str
    added: str | None
    evidence: str | None
    finding: det.Finding | None
    state: LoopState
    diagnosis: Diagnosis
    trials: list[Trial]

    @property
    def errors(self) -> ResidualErrors:
        return self.diagnosis.errors


@dataclass
class LoopResult:
    """The loop on one axis: its steps, the final verdict and what remains unexplained."""

    axis: str | None
    dt: float
    n: int
    steps: list[LoopStep]
    passed: bool
    verdict: str
    remaining: list[det.Finding]

    @property
    def final(self) -> LoopStep:
        return self.steps[-1]


def _default_fitter() -> Fitter:
    from ..core.estimation.fit import fit_model

    return fit_model


def _canonical(components: list[Component]) -> list[Component]:
    order = {name: i for i, name in enumerate(CANONICAL_ORDER)}
    return sorted(components, key=lambda c: order.get(c.name, len(order)))


def _call_fitter(fitter: Fitter, y: np.ndarray, dt: float, state: LoopState, *, exog: np.ndarray | None,
                 exog_names: list[str]) -> Any:
    kwargs: dict[str, Any] = {}
    if exog is not None:
        kwargs["exog"] = exog
        kwargs["exog_names"] = exog_names
    if state.init is not None:
        kwargs["init"] = state.init
    if "uncertainty" in inspect.signature(fitter).parameters:
        kwargs["uncertainty"] = False  # the loop compares fits; intervals are the EM stage's job
    return fitter(y, dt, structure_name(state.structure), **kwargs)


def _coef(fit: Any, names: list[str]) -> np.ndarray:
    """The fitted coefficients of the loop's regressors, in ``names`` order."""
    return np.array([float(fit.exog_coef[name]["value"]) for name in names])


def _fill_missing(y: np.ndarray) -> np.ndarray:
    """Linear interpolation over NaN samples (for the Allan variance, which needs a gap-free series)."""
    bad = ~np.isfinite(y)
    if not bad.any():
        return y
    idx = np.arange(y.size)
    out = y.copy()
    out[bad] = np.interp(idx[bad], idx[~bad], y[~bad])
    return out


def _n_params(fit: Any) -> float:
    """Free parameters of a fit (``n_params``, else recovered from its BIC = k·ln n − 2ℓ)."""
    k = getattr(fit, "n_params", 0)
    return float(k) if k else (float(fit.bic) + 2.0 * float(fit.loglik)) / math.log(float(fit.n))


class _Loop:
    def __init__(self, y: np.ndarray, dt: float, temperature: np.ndarray | None, fitter: Fitter, *,
                 alpha: float, lags: int, outliers: str) -> None:
        self.y, self.dt, self.temperature, self.outliers = y, dt, temperature, outliers
        self.fitter, self.alpha, self.lags = fitter, alpha, lags
        self.n_observed = int(np.isfinite(y).sum())
        self.n = y.size

    def exog(self, state: LoopState) -> tuple[np.ndarray | None, list[str], list[slice]]:
        cols, names, slices, start = [], [], [], 0
        for i, term in enumerate(state.exog_terms):
            c = term.columns(self.n, self.dt, self.temperature)
            cols.append(c)
            names += [f"{term.effect}{i + 1}_{j}" for j in range(c.shape[1])]
            slices.append(slice(start, start + c.shape[1]))
            start += c.shape[1]
        return (np.hstack(cols) if cols else None), names, slices

    def diagnose(self, state: LoopState) -> Diagnosis:
        y = self.y.copy()
        if state.flagged.size:
            y[state.flagged] = np.nan if self.outliers == "missing" else state.imputed
        exog, exog_names, slices = self.exog(state)
        fit = _call_fitter(self.fitter, y, self.dt, state, exog=exog, exog_names=exog_names)
        coef = _coef(fit, exog_names)
        exog_values = {f"{t.effect}{i + 1}": t.describe(coef[s])
                       for i, (t, s) in enumerate(zip(state.exog_terms, slices, strict=True))}
        residual_data = y - (exog @ coef if exog is not None else 0.0)
        filled = _fill_missing(residual_data)
        # τ up to a tenth of the record, where each AV estimate still has ≳ 10 degrees of freedom.
        m = choose_m(self.n, "allan", m_max=max(2, self.n // 10))
        av_model = np.asarray(fit.theoretical_allan_variance(m * self.dt), dtype=float)
        # The AV's confidence intervals under the null "the model holds": the noise type at each τ (which
        # sets the EDF) is read from the model's smooth AV, not from the noisy data.
        alpha_model = identify_alpha(m * self.dt, av_model[:, None], "allan")
        av = allan_variance(filled, self.dt, m=m, alpha=alpha_model)
        av_data = av.variance[:, 0]
        av_ci = (av.ci_low[:, 0], av.ci_high[:, 0])
        e = np.asarray(fit.standardized_innovations(), dtype=float).copy()
        e[: min(10, e.size // 100)] = np.nan  # start-up transient of the filter
        whitening = WhiteningFilter.from_components(list(fit.components), self.dt)
        k = state.flagged.size
        loglik = float(fit.loglik)
        if self.outliers == "missing":
            loglik -= 0.5 * k * math.log(2.0 * math.pi * whitening.innovation_variance)
        # Searched locations are parameters too: a line's frequency, a step's sample (max over M positions).
        searched = sum(t.effect in ("SIN", "STEP") for t in state.exog_terms)
        bic = -2.0 * loglik + (_n_params(fit) + k + searched) * math.log(self.n_observed)
        errors = residual_errors(e, self.dt, loglik=loglik, bic=bic, av_data=av_data, av_model=av_model,
                                 lags=self.lags)
        white = [c for c in fit.components if c.name in ("WN", "QN")]
        av_white = total_allan_variance(white, av.tau, self.dt) if white else None
        findings = self.detect(e, whitening, state, tau=av.tau, av_data=av_data, av_ci=av_ci, av_model=av_model,
                               av_white=av_white)
        return Diagnosis(fit=fit, errors=errors, findings=findings, innovations=e, tau=av.tau, av_data=av_data,
                         av_ci=av_ci, av_model=av_model, exog_values=exog_values,
                         innovation_variance=whitening.innovation_variance)

    def detect(self, e: np.ndarray, whitening: WhiteningFilter, state: LoopState, *, tau: np.ndarray,
               av_data: np.ndarray, av_ci: tuple[np.ndarray, np.ndarray], av_model: np.ndarray,
               av_white: np.ndarray | None) -> list[det.Finding]:
        a = self.alpha
        found = [det.detect_outliers(e, alpha=a), det.detect_sinusoid(e, self.dt, whitening, alpha=a),
                 det.detect_step(e, self.dt, whitening, alpha=a), det.detect_correlation(e, self.dt, alpha=a,
                                                                                        lags=self.lags)]
        if "RR" not in state.structure:
            found.append(det.detect_ramp(e, self.dt, whitening, alpha=a))
        if self.temperature is not None and not any(t.effect == "TEMP" for t in state.exog_terms):
            found.append(det.detect_temperature(e, self.temperature, whitening, alpha=a))
        found += det.detect_av_signatures(tau, av_data, av_ci, av_model, av_white=av_white, alpha=a)
        return found

    def candidates(self, diag: Diagnosis, state: LoopState) -> list[det.Finding]:
        """Significant findings that can be added, ranked by p-value: the most significant one per effect, except
        that Gauss–Markov candidates from distinct τ bands (an AV bump and a bounded long-τ AV) are kept apart;
        Ljung–Box evidence merges into the strongest GM band (which locates τ) or stands alone without one."""
        best: dict[str, det.Finding] = {}
        gms: list[det.Finding] = []
        lb: det.Finding | None = None
        for f in diag.findings:
            if not f.significant or not self.addable(f, state):
                continue
            if f.effect == "GM" and f.detector == "ljung_box":
                lb = f
            elif f.effect == "GM":
                gms.append(f)
            elif f.effect not in best or f.log10_p < best[f.effect].log10_p:
                best[f.effect] = f
        gms.sort(key=lambda f: f.log10_p)
        if gms and lb is not None:
            gms[0] = replace(gms[0], log10_p=min(gms[0].log10_p, lb.log10_p),
                             evidence=gms[0].evidence + "; " + lb.evidence)
        elif lb is not None:
            gms = [lb]
        return sorted([*best.values(), *gms[:2]], key=lambda f: f.log10_p)

    def addable(self, f: det.Finding, state: LoopState) -> bool:
        if f.effect in ("RW", "RR", "QN"):
            return f.effect not in state.structure
        if f.effect == "TEMP":
            return not any(t.effect == "TEMP" for t in state.exog_terms)
        return True

    def extend(self, state: LoopState, f: det.Finding, diag: Diagnosis) -> LoopState:
        fitted = list(diag.fit.components)
        new = LoopState(structure=list(state.structure), exog_terms=list(state.exog_terms),
                        flagged=state.flagged.copy(), imputed=state.imputed.copy(), init=fitted)
        if f.effect in STATE_EFFECTS:
            if f.params.get("deficit"):
                # The model's long-τ growth absorbed a bounded process: restart that growth small.
                fitted = [type(c)(c.params()["random_walk"] * 1e-2) if c.name == "RW" else c for c in fitted]
            new.structure = [c.name for c in _canonical([*fitted, self.component(f, diag)])]
            new.init = _canonical([*fitted, self.component(f, diag)])
        elif f.effect == "SIN":
            new.exog_terms.append(ExogTerm("SIN", {"frequency": f.params["frequency"]}))
        elif f.effect == "TEMP":
            new.exog_terms.append(ExogTerm("TEMP", {}))
        elif f.effect == "STEP":
            new.exog_terms.append(ExogTerm("STEP", {"index": f.params["index"], "time": f.params["time"]}))
        elif f.effect == "OUTLIERS":
            fresh = np.setdiff1d(f.indices, state.flagged)
            prediction = self.y[fresh] - diag.innovations[fresh] * math.sqrt(diag.innovation_variance)
            order = np.argsort(np.concatenate([state.flagged, fresh]))
            new.flagged = np.concatenate([state.flagged, fresh])[order]
            new.imputed = np.concatenate([state.imputed, prediction])[order]
        return new

    def component(self, f: det.Finding, diag: Diagnosis) -> Component:
        """The state-space component a finding asks for, with the detector's values as initial values."""
        p = f.params
        if f.effect == "GM":
            sigma = p["sigma"] if "sigma" in p else p["sigma_share"] * math.sqrt(diag.innovation_variance)
            return GM(tau=max(float(p["tau"]), 2.0 * self.dt), sigma=max(float(sigma), 1e-12))
        if f.effect == "RW":
            return RW(max(float(p["random_walk"]), 1e-15))
        if f.effect == "QN":
            return QN(max(float(p["Q"]), 1e-15))
        return RR(float(p["slope"]))

    def targeted_statistic(self, f: det.Finding, diag: Diagnosis) -> float:
        """The statistic of the signature ``f`` targeted, re-measured at the same place on the new residuals."""
        e = diag.innovations
        w = WhiteningFilter.from_components(list(diag.fit.components), self.dt)
        if f.detector == "av_band":
            z = av_misfit_z(diag.av_data, diag.av_ci, diag.av_model)
            band = (diag.tau >= f.params["band_lo"] * 0.999) & (diag.tau <= f.params["band_hi"] * 1.001)
            z = -z if f.params.get("deficit") else z
            return float(np.max(z[band])) if band.any() else 0.0
        if f.effect == "SIN":
            return line_statistic(e, self.dt, f.params["frequency"])
        if f.effect == "OUTLIERS":
            return det.detect_outliers(e, alpha=f.level, only=f.indices).statistic
        if f.effect == "STEP":
            m = max(20, self.n // 200)
            k = int(f.params["index"])
            near = np.abs(det.step_scan(e, w, m)[max(0, k - m): k + m + 1])
            return float(np.nanmax(near)) if np.isfinite(near).any() else 0.0
        rerun = {
            "temperature_score": lambda: det.detect_temperature(e, self.temperature, w, alpha=f.level),
            "ramp_score": lambda: det.detect_ramp(e, self.dt, w, alpha=f.level),
            "ljung_box": lambda: det.detect_correlation(e, self.dt, alpha=f.level, lags=self.lags),
        }
        return float(rerun[f.detector]().statistic)

    def evidence_gone(self, f: det.Finding, diag: Diagnosis) -> tuple[bool, str]:
        """Whether the signature ``f`` targeted is gone from the new fit's residuals.

        Gone: its statistic, re-measured at the same place (frequency, sample, τ band, samples), is below its
        threshold, or has fallen to less than half its value (measured effects are rarely exactly the shape
        added, e.g. a wandering line, a band-limited bump; what is left is new evidence for the next step).
        """
        stat = self.targeted_statistic(f, diag)
        below = stat <= f.threshold
        halved = stat <= 0.5 * f.statistic
        word = "gone" if below else ("halved" if halved else "still there")
        return below or halved, f"{f.detector} statistic {f.statistic:.1f} → {stat:.1f} (threshold " \
                                f"{f.threshold:.1f}): {word}"


def run_closed_loop(
    y: np.ndarray,
    dt: float,
    start_structure: str,
    *,
    temperature: np.ndarray | None = None,
    fitter: Fitter | None = None,
    max_steps: int = 6,
    max_candidates: int = 3,
    alpha: float = det.ALPHA,
    lags: int = 20,
    outliers: str = "impute",
    axis: str | None = None,
) -> LoopResult:
    """Run the closed loop on one axis (see the module docstring for the rules).

    Parameters
    ----------
    y : (N,) array
        Samples of one axis [u] (rad/s or m/s²) at period ``dt``; NaN = missing.
    dt : float
        Sampling period [s].
    start_structure : str
        Starting model structure, e.g. ``"WN+RW"``.
    temperature : (N,) array, optional
        Sensor temperature [°C] at the sample times (see :func:`align_temperature`); enables ``TEMP``.
    fitter : callable, optional
        ``fitter(y, dt, structure, exog=..., [init=...])`` returning a FitResult; default
        :func:`imu_noise_id.core.estimation.fit.fit_model`.
    max_steps : int
        At most this many effects are added.
    max_candidates : int
        Candidates refitted per step.
    alpha : float
        Level of every detector.
    lags : int
        Ljung–Box lags.
    outliers : {"impute", "missing"}
        How flagged outliers are removed (see the module docstring).
    axis : str, optional
        Axis name, for the report.

    Raises
    ------
    InputError
        Bad input (not 1-D, inf, too few samples, temperature of another length or not finite).
    """
    y = np.asarray(y, dtype=float)
    if y.ndim != 1:
        raise InputError(f"closed loop: samples of one axis expected (1-D), got shape {y.shape}")
    if np.any(np.isinf(y)):
        raise InputError("closed loop: samples contain inf")
    if int(np.isfinite(y).sum()) < 1000:
        raise InputError(f"closed loop: need at least 1000 finite samples, got {int(np.isfinite(y).sum())}")
    if not (np.isfinite(dt) and dt > 0):
        raise InputError(f"closed loop: sampling period must be > 0, got {dt!r}")
    if temperature is not None:
        temperature = np.asarray(temperature, dtype=float)
        if temperature.shape != y.shape or not np.all(np.isfinite(temperature)):
            raise InputError("closed loop: temperature must be finite and aligned with the samples "
                             "(use align_temperature)")
        if np.ptp(temperature) <= 0:
            temperature = None
    if max_steps < 0 or max_candidates < 1:
        raise InputError("closed loop: max_steps must be >= 0 and max_candidates >= 1")
    if outliers not in ("impute", "missing"):
        raise InputError(f"closed loop: outliers must be 'impute' or 'missing', got {outliers!r}")
    loop = _Loop(y, float(dt), temperature, fitter or _default_fitter(), alpha=alpha, lags=lags, outliers=outliers)
    state = LoopState(structure=parse_structure(start_structure))
    diag = loop.diagnose(state)
    steps = [LoopStep(0, state.name(), None, None, None, state, diag, [])]
    verdict, passed = "", False
    while True:
        cands = loop.candidates(diag, state)
        if not cands:
            left = sorted({f.effect for f in diag.findings if f.significant})
            passed = not left
            verdict = ("residuals pass: no detector fires at its level" if passed else
                       f"nothing more can be added: evidence for {', '.join(left)} remains, but these effects "
                       "are already in the model")
            break
        if len(steps) > max_steps:
            verdict = f"stopped after {max_steps} added effects; residual evidence remains"
            break
        trials: list[Trial] = []
        best: tuple[float, LoopState, Diagnosis, det.Finding] | None = None
        for f in cands[:max_candidates]:
            new_state = loop.extend(state, f, diag)
            try:
                new_diag = loop.diagnose(new_state)
                if new_diag.errors.loglik < diag.errors.loglik and new_state.init is not None:
                    # Nested models cannot lose likelihood: a local optimum. Refit from the estimator's own starts.
                    new_state.init = None
                    retry = loop.diagnose(new_state)
                    new_diag = retry if retry.errors.loglik > new_diag.errors.loglik else new_diag
            except (InputError, ValueError, np.linalg.LinAlgError) as exc:
                trials.append(Trial(f, new_state.name(), None, False, f"refit failed: {exc}"))
                continue
            bic_new = new_diag.errors.bic
            improved = bic_new < diag.errors.bic
            gone, why = loop.evidence_gone(f, new_diag)
            ok = improved and gone
            reason = (f"BIC {diag.errors.bic:.1f} → {bic_new:.1f} ({'better' if improved else 'not better'}); "
                      f"{why}")
            trials.append(Trial(f, new_state.name(), bic_new, ok, reason))
            if ok and (best is None or bic_new < best[0]):
                best = (bic_new, new_state, new_diag, f)
        if best is None:
            verdict = "nothing improves: no candidate lowered the BIC with its evidence gone"
            steps[-1].trials = trials
            break
        _, state, diag, f = best
        steps[-1].trials = trials
        steps.append(LoopStep(len(steps), state.name(), f.effect, f.evidence, f, state, diag, []))
    remaining = [f for f in diag.findings if f.significant]
    return LoopResult(axis=axis, dt=float(dt), n=y.size, steps=steps, passed=passed, verdict=verdict,
                      remaining=remaining)


def align_temperature(t_samples: np.ndarray, t_temperature: np.ndarray, temperature: np.ndarray) -> np.ndarray:
    """Temperature [°C] at the IMU sample times by linear interpolation (held constant beyond its ends).

    Raises
    ------
    InputError
        Fewer than two temperature samples, non-finite values, or non-increasing temperature times.
    """
    t_temperature = np.asarray(t_temperature, dtype=float)
    temperature = np.asarray(temperature, dtype=float)
    if t_temperature.size < 2 or t_temperature.shape != temperature.shape:
        raise InputError("temperature topic: need at least two samples with stamps")
    if not (np.all(np.isfinite(temperature)) and np.all(np.isfinite(t_temperature))):
        raise InputError("temperature topic holds NaN/inf values")
    if np.any(np.diff(t_temperature) <= 0):
        raise InputError("temperature topic: stamps are not strictly increasing")
    return np.interp(np.asarray(t_samples, dtype=float), t_temperature, temperature)


def block_average(y: np.ndarray, factor: int) -> np.ndarray:
    """Means of consecutive blocks of ``factor`` samples (NaN-aware; a block of only NaN stays NaN).

    Averaging keeps every effect slower than the new Nyquist frequency 1/(2·factor·dt) and divides the white
    noise variance by ``factor`` (its density is unchanged); the closed loop on long records runs on it.
    """
    if factor < 1:
        raise InputError(f"decimation factor must be >= 1, got {factor}")
    y = np.asarray(y, dtype=float)
    if factor == 1:
        return y
    n = (y.size // factor) * factor
    blocks = y[:n].reshape(-1, factor)
    counts = np.isfinite(blocks).sum(axis=1)
    sums = np.nansum(blocks, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)


def run_closed_loop_imu(
    imu: ImuSeries,
    start: str | dict[str, str],
    *,
    temperature: ScalarSeries | None = None,
    axes: tuple[str, ...] = AXES,
    decimate: int = 1,
    **loop_kwargs: Any,
) -> dict[str, LoopResult]:
    """The closed loop on several axes of an IMU recording (what ``analyze`` and ``loop`` call).

    Parameters
    ----------
    imu : ImuSeries
        The recording (its median period is the sampling period).
    start : str or dict
        Starting structure for every axis, or per axis (e.g. the model ``select_model`` chose).
    temperature : ScalarSeries, optional
        The bag's temperature topic; interpolated onto the IMU stamps (enables ``TEMP``).
    axes : tuple of str
        Axes to run.
    decimate : int
        Block-average this many samples first (long records on small machines); the report states it.
    loop_kwargs
        Passed to :func:`run_closed_loop`.
    """
    dt = imu.dt * decimate
    temp = None
    if temperature is not None:
        temp = block_average(align_temperature(imu.t, temperature.t, temperature.value), decimate)
    results = {}
    for axis in axes:
        structure = start[axis] if isinstance(start, dict) else start
        y = block_average(imu.axis(axis), decimate)
        results[axis] = run_closed_loop(y, dt, structure, temperature=temp, axis=axis, **loop_kwargs)
    return results
