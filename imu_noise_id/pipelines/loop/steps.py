"""One axis of the closed loop: fit and diagnose a step, propose candidate effects, add one, judge the result."""

from __future__ import annotations

import functools
import math
from dataclasses import replace

import numpy as np

from ...core.allan import AllanResult, allan_variance, choose_m
from ...core.deferred import Deferred
from ...core.diagnostics import detectors as det
from ...core.diagnostics.av_band import model_av_band
from ...core.diagnostics.av_signatures import detect_av_signatures, white_allan_variance
from ...core.diagnostics.lines import (
    detect_broad_line,
    detect_innovation_hump,
    harmonics,
    line_shape,
    pooled_line_statistic,
)
from ...core.diagnostics.residuals import LINE_SEPARATION_BINS, av_misfit_z, line_statistic, residual_errors
from ...core.diagnostics.spectra import residual_spectra
from ...core.diagnostics.whitening import WhiteningFilter
from ...core.estimation.em import composite, screen
from ...core.estimation.em.model import FitOptions, NoiseModel
from ...core.estimation.em.relabel import gm_as_filter
from ...core.estimation.em.results import FitResult
from ...core.noise.components import BI, GM, MA, QN, RR, RW, WN, Component
from ...core.noise.flicker import band_for_record
from ...core.noise.modelspec import canonical, structure_name
from ...core.noise.resonant import LPF, MAX_DAMPING, OSC, filter_memory_limit
from ...core.quality import interpolate_missing
from .state import STATE_EFFECTS, Diagnosis, ExogTerm, LoopState


def _restarted_walk(fitted: float, f: det.Finding) -> float:
    """The random walk a refit restarts from after a long-τ deficit: the finding's remaining walk when it has one
    below the fitted (an AV deficit finding's joint GM + RW fit), else 1 % of the fitted."""
    left = f.params.get("random_walk")
    return float(left) if left is not None and 0.0 < left < fitted else fitted * 1e-2


#: Line concentrations outside this range decide SIN (above) or OSC (below) alone; inside it both are tried.
DECISIVE_SHARE = (0.2, 0.9)


def _coef(fit: FitResult, names: list[str]) -> np.ndarray:
    """The fitted coefficients of the loop's regressors, in ``names`` order."""
    return np.array([float(fit.exog_coef[name]["value"]) for name in names])


class AxisLoop:
    """An axis's record with the loop's settings: fits and diagnoses a :class:`LoopState`, adds and judges effects."""

    def __init__(self, y: np.ndarray, dt: float, temperature: np.ndarray | None, *, alpha: float, lags: int,
                 outliers: str) -> None:
        self.y, self.dt, self.temperature, self.outliers = y, dt, temperature, outliers
        self.alpha, self.lags = alpha, lags
        self.n_observed = int(np.isfinite(y).sum())
        self.n = y.size
        # the floor a white noise a fit drove to ~0 restarts from (docs/loop.md, "Why the loop's moves …")
        d = np.diff(y[np.isfinite(y)])
        self.white_floor = 1e-3 * math.sqrt(max(float(np.var(d)) / 2.0, 1e-300) * dt)
        self._cleaned: tuple[bytes, composite.CompositeStatistics] | None = None  # :meth:`cleaned_statistics`

    @property
    def on_composite(self) -> bool:
        """Whether this record's moves are fitted on the composite likelihood of fixed size (:meth:`fit_state`)."""
        return self.n >= composite.MIN_SAMPLES

    @functools.cached_property
    def composite_statistics(self) -> composite.CompositeStatistics:
        """The record's composite-likelihood statistics (:mod:`~imu_noise_id.core.estimation.em.composite`), once."""
        return composite.CompositeStatistics.of(self.y, self.dt)

    def fit_state(self, model: NoiseModel, state: LoopState, *, exact: bool = False) -> FitResult:
        """The fit of ``state`` (``model`` its record and regressors) from ``state.init`` (None: the estimator's
        starts): unless ``exact``, from ``composite.MIN_SAMPLES`` samples on, the composite likelihood's maximiser
        (:func:`.composite.fit`, the regressors at their GLS values from the start removed) evaluated once on the exact
        likelihood, means by GLS; else the exact ML fit (with ``exact``, a refinement of ``state.init``: the finish
        alone, stopped once the likelihood stalls). Beyond the papers (docs/em.md, "Searching long records …")."""
        if exact and state.init is not None:
            return model.fit(state.init, FitOptions(uncertainty=False, em_iter=0, stop_stalled=True))
        if exact or not self.on_composite:
            # The loop compares fits; intervals are the model selection's job.
            return model.fit(state.init, FitOptions(uncertainty=False))
        starts = [state.init] if state.init is not None else model.starting_values(FitOptions().n_starts, True)
        if model.exog_names:
            names = list(model.exog_names)
            at_start = model.fit(starts[0], FitOptions(em_iter=0, polish=False, uncertainty=False, spectral_init=False))
            stats = composite.CompositeStatistics.of(model.y - model.z[:, -len(names):] @ _coef(at_start, names),
                                                     self.dt)
        elif state.flagged.size:
            stats = self.cleaned_statistics(state, model.y)
        else:
            stats = self.composite_statistics
        return composite.fit_model(model, starts, stats)

    def cleaned_statistics(self, state: LoopState, y: np.ndarray) -> composite.CompositeStatistics:
        """The composite statistics of ``y``, the record with ``state``'s removed samples imputed (or missing): kept
        for the next state that removes the same samples (a step's candidates all do), computed afresh when they
        change."""
        key = state.flagged.tobytes() + np.asarray(state.imputed, dtype=float).tobytes()
        if self._cleaned is None or self._cleaned[0] != key:
            self._cleaned = (key, composite.CompositeStatistics.of(y, self.dt))
        return self._cleaned[1]

    @functools.cached_property
    def statistics(self) -> screen.Statistics:
        """The record's screening statistics (:mod:`~imu_noise_id.core.estimation.em.screen`), computed once."""
        return screen.Statistics.of(self.filled, self.dt)

    def screen_reference(self, state: LoopState, diag: Diagnosis) -> screen.Reference | None:
        """The fit of ``diag`` on the screening statistics; None below ``screen.MIN_SAMPLES`` samples or with
        regressors or removed samples in ``state``."""
        if self.n < screen.MIN_SAMPLES or state.exog_terms or state.flagged.size:
            return None
        return screen.Reference.fit(list(diag.fit.components), self.statistics)

    def exog(self, state: LoopState) -> tuple[np.ndarray | None, list[str], list[slice]]:
        cols, names, slices, start = [], [], [], 0
        for i, term in enumerate(state.exog_terms):
            c = term.columns(self.n, self.dt, self.temperature)
            cols.append(c)
            names += [f"{term.effect}{i + 1}_{j}" for j in range(c.shape[1])]
            slices.append(slice(start, start + c.shape[1]))
            start += c.shape[1]
        return (np.hstack(cols) if cols else None), names, slices

    def diagnose(self, state: LoopState, fit: FitResult | None = None, *, exact: bool = False) -> Diagnosis:
        """Fit ``state`` (:meth:`fit_state`, ``exact`` or not) unless its ``fit`` on this record is given; diagnose."""
        y = self.y.copy()
        if state.flagged.size:
            y[state.flagged] = np.nan if self.outliers == "missing" else state.imputed
        exog, exog_names, slices = self.exog(state)
        if fit is None:
            model = NoiseModel(y, self.dt, structure_name(state.structure), exog=exog, exog_names=exog_names)
            fit = self.fit_state(model, state, exact=exact)
        fit = gm_as_filter(fit)
        state.structure = [c.name for c in fit.components if c.name != "RR" or "RR" in state.structure]
        coef = _coef(fit, exog_names)
        exog_values = {f"{t.effect}{i + 1}": t.describe(coef[s])
                       for i, (t, s) in enumerate(zip(state.exog_terms, slices, strict=True))}
        as_recorded = exog is None and not state.flagged.size
        filled = self.filled if as_recorded else interpolate_missing(y - (exog @ coef if exog is not None else 0.0))
        av = self.record_allan if as_recorded else self.allan(filled)
        m = self.av_factors
        av_model = np.asarray(fit.theoretical_allan_variance(m * self.dt), dtype=float)
        av_data = av.variance[:, 0]
        # the AV's intervals under the fitted model, with its exact EDF (docs/loop.md, "Residuals and error measures")
        av_ci = model_av_band(av_data, list(fit.components), m, filled.size, self.dt)
        e = np.asarray(fit.standardized_innovations(), dtype=float)
        fit = replace(fit, standardized=None)  # kept once, as the diagnosis's innovations
        e[: min(10, e.size // 100)] = np.nan  # start-up transient of the filter
        whitening = WhiteningFilter.from_components(list(fit.components), self.dt)
        k = state.flagged.size
        loglik = float(fit.loglik)
        if self.outliers == "missing":
            loglik -= 0.5 * k * math.log(2.0 * math.pi * whitening.innovation_variance)
        # Searched locations are parameters too: a line's frequency, a step's sample (max over M positions).
        searched = sum(t.effect in ("SIN", "STEP") for t in state.exog_terms)
        bic = -2.0 * loglik + (fit.n_params + k + searched) * math.log(self.n_observed)
        errors = residual_errors(e, self.dt, loglik=loglik, bic=bic, av_data=av_data, av_model=av_model,
                                 lags=self.lags)
        av_white = white_allan_variance(fit.components, av.tau, self.dt)
        detected = Deferred(functools.partial(
            self.detect, e, whitening, tuple(state.structure), tuple(t.effect for t in state.exog_terms), filled,
            tau=av.tau, av_data=av_data, av_ci=av_ci, av_model=av_model, av_white=av_white))
        return Diagnosis(fit=fit, errors=errors, detected=detected, innovations=e, tau=av.tau, av_data=av_data,
                         av_ci=av_ci, av_model=av_model, exog_values=exog_values,
                         whitening=whitening,
                         residual_spectra=Deferred(functools.partial(residual_spectra, e, self.dt)))

    @functools.cached_property
    def av_factors(self) -> np.ndarray:
        """The averaging factors m of the diagnoses' AV: τ = m·dt up to a tenth of the record (docs/loop.md,
        "Residuals and error measures")."""
        return choose_m(self.n, "allan", m_max=max(2, self.n // 10))

    def allan(self, filled: np.ndarray) -> AllanResult:
        """The overlapping AV at :attr:`av_factors` of a residual ``filled`` (its missing samples interpolated)."""
        return allan_variance(filled, self.dt, m=self.av_factors, alpha=0)

    @functools.cached_property
    def filled(self) -> np.ndarray:
        """The record with its missing samples interpolated, a read-only copy: the residual of every state without
        regressors or removed samples, shared by their diagnoses."""
        filled = np.array(interpolate_missing(self.y), dtype=float)
        filled.flags.writeable = False
        return filled

    @functools.cached_property
    def record_allan(self) -> AllanResult:
        """:meth:`allan` of :attr:`filled`, computed once for the diagnoses that share it."""
        return self.allan(self.filled)

    def detect(self, e: np.ndarray, whitening: WhiteningFilter, structure: tuple[str, ...], regressors: tuple[str, ...],
               residual: np.ndarray, *, tau: np.ndarray, av_data: np.ndarray, av_ci: tuple[np.ndarray, np.ndarray],
               av_model: np.ndarray, av_white: np.ndarray | None) -> list[det.Finding]:
        """Every detector on the standardized innovations ``e`` of a fit of ``structure`` with the regressor effects
        ``regressors`` (``residual``: the data less the regressors, gaps filled; the AV readings at ``tau``)."""
        a = self.alpha
        whitening = replace(whitening)  # its whitened constant kept for these detectors only, not with the diagnosis
        found = [det.detect_outliers(e, alpha=a), *self.detect_line(e, whitening, residual),
                 det.detect_step(e, self.dt, whitening, alpha=a), det.detect_correlation(e, self.dt, alpha=a,
                                                                                        lags=self.lags)]
        if "RR" not in structure:
            found.append(det.detect_ramp(e, self.dt, whitening, alpha=a))
        if self.temperature is not None and "TEMP" not in regressors:
            found.append(det.detect_temperature(e, self.temperature, whitening, alpha=a))
        found += detect_av_signatures(tau, av_data, av_ci, av_model, av_white=av_white, alpha=a)
        return found

    def detect_line(self, e: np.ndarray, whitening: WhiteningFilter, residual: np.ndarray) -> list[det.Finding]:
        """The strongest narrow line (:func:`~imu_noise_id.core.diagnostics.detectors.detect_sinusoid`) and the
        strongest broad one (:func:`~imu_noise_id.core.diagnostics.lines.detect_broad_line`, skipping the narrow line's
        pooled bins and its harmonics'), each as a SIN finding and, when significant, an OSC finding."""
        sin, *others = det.detect_sinusoids(e, self.dt, whitening, alpha=self.alpha)
        narrow = self.line_findings(sin, e, residual, others=others) if sin.significant else []
        found = {float(m.params["frequency"]) for f in narrow for m in (f, *f.members)}
        broad = detect_broad_line(e, self.dt, alpha=self.alpha, exclude=tuple(sorted(found)))
        wide = self.line_findings(broad, e, residual) if broad.significant else []
        return [*narrow, *wide] if narrow or wide else [sin]

    def line_findings(self, sin: det.Finding, e: np.ndarray, residual: np.ndarray,
                      others: list[det.Finding] | tuple[det.Finding, ...] = ()) -> list[det.Finding]:
        """A significant line as its SIN and OSC findings (harmonic family or :meth:`line_group`), ordered by its shape
        (``lines.line_shape``: look-alike first, the OSC's f₀, bandwidth, σ); outside :data:`DECISIVE_SHARE` only the
        look-alike. ``others``: the weaker significant narrow lines."""
        shape = line_shape(residual, self.dt, sin.params["frequency"], resolution=int(sin.params.get("resolution", 1)))
        evidence = f"{sin.evidence}; {shape.reason}"
        bandwidth = min(shape.bandwidth, MAX_DAMPING * shape.frequency)  # ζ ≤ MAX_DAMPING / 2
        searched = {"line_frequency": sin.params["frequency"], "resolution": sin.params.get("resolution", 1)}
        osc = replace(sin, effect="OSC", evidence=evidence,
                      params={"frequency": shape.frequency, "bandwidth": bandwidth, "sigma": max(shape.sigma, 1e-12),
                              "concentration": shape.concentration, **searched})
        sin = replace(sin, evidence=evidence, params={**sin.params, "frequency": shape.frequency
                                                      if sin.detector == "pooled_periodogram"
                                                      else sin.params["frequency"],
                                                      "concentration": shape.concentration, **searched})
        first, second = (sin, osc) if shape.kind == "SIN" else (osc, sin)
        family = self.harmonic_family(first, e, residual)
        if shape.concentration >= DECISIVE_SHARE[1]:
            family = self.line_group(first, family, others, residual) or family
        if not DECISIVE_SHARE[0] < shape.concentration < DECISIVE_SHARE[1]:
            return [*family, first]  # the shape leaves no doubt: the look-alike only
        return [*family, replace(first, log10_p=first.log10_p - 1e-9), second]

    def line_group(self, first: det.Finding, family: list[det.Finding], others: list[det.Finding] | tuple[
            det.Finding, ...], residual: np.ndarray) -> list[det.Finding]:
        """The strongest line, its harmonics and every other significant narrow line (family-wise level,
        ``detectors.detect_sinusoids``) that is a sinusoid beyond doubt (:data:`DECISIVE_SHARE`), as one finding; []
        when no other line qualifies. Beyond the papers (docs/loop.md, "Many narrow lines in one step")."""
        members = list(family[0].members) if family else [first]
        resolution = 1.0 / (self.n * self.dt)
        near = resolution * (LINE_SEPARATION_BINS + 1)
        added = []
        for line in others:
            f = float(line.params["frequency"])
            if any(abs(f - float(m.params["frequency"])) <= near for m in members):
                continue
            if line_shape(residual, self.dt, f).concentration < DECISIVE_SHARE[1]:
                continue
            members.append(line)
            added.append(f)
        if not added:
            return []
        listed = ", ".join(f"{f:.5g}" for f in added)
        return [replace(first, log10_p=first.log10_p - 2e-9, members=tuple(members),
                        evidence=f"{(family[0] if family else first).evidence}; with {len(added)} more narrow "
                                 f"line(s), each significant on its own: SIN at {listed} Hz")]

    def harmonic_family(self, line: det.Finding, e: np.ndarray, residual: np.ndarray) -> list[det.Finding]:
        """The line and its significant harmonics (:func:`~imu_noise_id.core.diagnostics.lines.harmonics`) as one
        finding, SINs at exact multiples or OSCs shaped at each; [] without harmonics."""
        f0 = line.params["frequency"]
        bandwidth = line.params.get("bandwidth", 0.0)
        found = harmonics(e, self.dt, f0, bandwidth, alpha=self.alpha)
        if not found:
            return []
        members = [line]
        for h in found:
            if line.effect == "SIN":
                k = round(h / f0)
                members.append(replace(line, params={**line.params, "frequency": k * f0}))
            else:
                shape = line_shape(residual, self.dt, h)
                members.append(replace(line, params={**line.params, "frequency": shape.frequency,
                                                     "bandwidth": min(shape.bandwidth, MAX_DAMPING * shape.frequency),
                                                     "sigma": max(shape.sigma, 1e-12)}))
        listed = ", ".join(f"{m.params['frequency']:.4g}" for m in members)
        return [replace(line, log10_p=line.log10_p - 2e-9, members=tuple(members),
                        evidence=f"{line.evidence}; with its harmonics: {line.effect} at {listed} Hz")]

    def candidates(self, diag: Diagnosis, state: LoopState) -> list[det.Finding]:
        """Significant addable findings by p-value: the most significant per effect, GM candidates of distinct τ bands
        and narrow and broad lines kept apart; Ljung–Box evidence merged into the strongest GM band, or alone."""
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
            else:
                # A family and the line alone both stay, and so do a narrow and a broad line.
                key = f"{f.effect}:{f.detector}" if f.effect in ("SIN", "OSC") else f.effect
                key = f"{key} family" if f.members else key
                if key not in best or f.log10_p < best[key].log10_p:
                    best[key] = f
        gms.sort(key=lambda f: f.log10_p)
        if gms and lb is not None:
            gms[0] = replace(gms[0], log10_p=min(gms[0].log10_p, lb.log10_p),
                             evidence=gms[0].evidence + "; " + lb.evidence)
        elif lb is not None:
            gms = [lb]
        gms = [g for f in gms[:2] for g in self.as_filter(f, state)]
        return sorted([*best.values(), *gms], key=lambda f: f.log10_p)

    def as_filter(self, f: det.Finding, state: LoopState) -> list[det.Finding]:
        """A GM finding (not a long-τ deficit's) with τ below ``resonant.filter_memory_limit`` as the sensor's own
        filter: an LPF and an MA finding, each unless the model has it (docs/loop.md, "The loop's rules" 2)."""
        tau = f.params.get("tau")
        missing = [k for k in ("LPF", "MA") if k not in state.structure]
        if tau is None or tau >= filter_memory_limit(self.dt) or not missing or f.params.get("deficit"):
            return [f]
        memory = f"{f.evidence}; memory of {tau / self.dt:.1f} samples: the sensor's own"
        offer = {"LPF": replace(f, effect="LPF", evidence=f"{memory} low-pass filter"),
                 "MA": replace(f, effect="MA", log10_p=f.log10_p + 1e-9, evidence=f"{memory} averaging filter")}
        return [offer[k] for k in missing]

    def addable(self, f: det.Finding, state: LoopState) -> bool:
        if f.effect in ("RW", "RR", "QN", "LPF", "MA", "BI"):
            return f.effect not in state.structure
        if f.effect == "TEMP":
            return not any(t.effect == "TEMP" for t in state.exog_terms)
        return True

    def extend(self, state: LoopState, f: det.Finding, diag: Diagnosis) -> LoopState:
        if f.members:  # a family: each member added in turn
            for member in f.members:
                state = self.extend(state, member, diag)
                diag = replace(diag, fit=replace(diag.fit, components=list(state.init or diag.fit.components)))
            return state
        fitted = [WN(self.white_floor) if isinstance(c, WN) and c.noise_density < self.white_floor else c
                  for c in diag.fit.components]
        new = LoopState(structure=list(state.structure), exog_terms=list(state.exog_terms),
                        flagged=state.flagged.copy(), imputed=state.imputed.copy(), init=fitted)
        if f.effect in STATE_EFFECTS:
            if f.params.get("deficit"):
                # The model's long-τ growth absorbed a bounded process: restart that growth at what the finding
                # left of it, or small.
                fitted = [type(c)(_restarted_walk(c.params()["random_walk"], f)) if c.name == "RW" else c
                          for c in fitted]
            new.structure = [c.name for c in canonical([*fitted, self.component(f, diag)])]
            new.init = canonical([*fitted, self.component(f, diag)])
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
        if f.effect == "OSC":
            return OSC(frequency=float(p["frequency"]), bandwidth=float(p["bandwidth"]), sigma=float(p["sigma"]))
        if f.effect in ("GM", "LPF", "MA"):
            return self._short_memory(f, diag)
        # One positive amplitude from the detector (RR's slope may have either sign).
        if f.effect == "RR":
            return RR(float(p["slope"]))
        amplitude = {"BI": "bias_instability", "RW": "random_walk", "QN": "Q"}[f.effect]
        value = max(float(p[amplitude]), 1e-15)
        if f.effect == "BI":
            return BI(value, *band_for_record(self.n, self.dt))
        return {"RW": RW, "QN": QN}[f.effect](value)

    def _short_memory(self, f: det.Finding, diag: Diagnosis) -> Component:
        """A GM of the finding's (τ, σ), or, read as the sensor's own filter with the same passband density
        N = σ√(2τ), an LPF (σ² = π N² f_c, τ = 1/2πf_c) or an MA."""
        p = f.params
        sigma = p["sigma"] if "sigma" in p else p["sigma_share"] * math.sqrt(diag.innovation_variance)
        tau, sigma = max(float(p["tau"]), 2.0 * self.dt), max(float(sigma), 1e-12)
        if f.effect == "LPF":
            return LPF(noise_density=sigma * math.sqrt(2.0 * tau), cutoff=1.0 / (2.0 * math.pi * tau))
        if f.effect == "MA":
            return MA(noise_density=sigma * math.sqrt(2.0 * tau))
        return GM(tau=tau, sigma=sigma)

    def targeted_statistic(self, f: det.Finding, diag: Diagnosis) -> float:
        """The statistic of the signature ``f`` targeted, re-measured at the same place on the new residuals (a
        whole-record test, and the joint search's innovation hump, run again)."""
        e, w = diag.innovations, replace(diag.whitening)  # as in detect: no whitened constant kept with the diagnosis
        rerun = {
            "temperature_score": lambda: det.detect_temperature(e, self.temperature, w, alpha=f.level),
            "ramp_score": lambda: det.detect_ramp(e, self.dt, w, alpha=f.level),
            "ljung_box": lambda: det.detect_correlation(e, self.dt, alpha=f.level, lags=self.lags),
            "innovation_hump": lambda: detect_innovation_hump(e, self.dt, alpha=f.level).finding,
        }
        if f.detector in rerun:
            return float(rerun[f.detector]().statistic)
        if f.detector == "av_band":
            z = av_misfit_z(diag.av_data, diag.av_ci, diag.av_model)
            band = (diag.tau >= f.params["band_lo"] * 0.999) & (diag.tau <= f.params["band_hi"] * 1.001)
            z = -z if f.params.get("deficit") else z
            return float(np.max(z[band])) if band.any() else 0.0
        if f.detector == "pooled_periodogram":
            return pooled_line_statistic(e, self.dt, f.params["line_frequency"], int(f.params["resolution"]))
        if f.effect in ("SIN", "OSC"):
            return line_statistic(e, self.dt, f.params["line_frequency"])
        if f.effect == "OUTLIERS":
            return det.detect_outliers(e, alpha=f.level, only=f.indices).statistic
        if f.effect == "STEP":
            m = max(20, self.n // 200)
            k = int(f.params["index"])
            near = np.abs(det.step_scan(e, w, m)[max(0, k - m): k + m + 1])
            return float(np.nanmax(near)) if np.isfinite(near).any() else 0.0
        raise ValueError(f"no re-measure of a {f.detector} finding ({f.effect})")

    def evidence_gone(self, f: det.Finding, diag: Diagnosis) -> tuple[bool, str]:
        """Whether the signature ``f`` targeted is gone from the new fit's residuals: its statistic, re-measured at the
        same place (frequency, sample, τ band, samples), is below its threshold or below half its value."""
        stat = self.targeted_statistic(f, diag)
        below = stat <= f.threshold
        halved = stat <= 0.5 * f.statistic
        word = "gone" if below else ("halved" if halved else "still there")
        return below or halved, f"{f.detector} statistic {f.statistic:.1f} → {stat:.1f} (threshold " \
                                f"{f.threshold:.1f}): {word}"
