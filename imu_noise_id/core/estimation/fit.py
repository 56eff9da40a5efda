"""Batch identification of one axis: constrained EM (paper 000 §3) + quasi-Newton finish, CIs, model selection,
recording-length advice.

``fit_model`` → :class:`FitResult`; ``select_model`` → :class:`SelectionResult`. These are the API the
``fit`` / ``analyze`` commands and the closed loop (residual → missing effect → refit) call.

Pipeline of :func:`fit_model`:

1. input checks (InputError on constant, too short, all-NaN, inf, bad dt);
2. drift: with RR in the structure, ``drift='em'`` estimates the ramp jointly (a measurement regressor ``t·dt``
   whose coefficient is the slope, profiled by GLS in the likelihood and updated in closed form in the EM);
   ``drift='ls'`` removes a least-squares line first (paper 000 §3.5(iii)) and reports its slope;
3. initial values: ``init`` if given, else the Allan-variance fit (:mod:`.starts`) from several
   GM placements, each refined by a banded Whittle likelihood (:mod:`.whittle`), the distinct
   best ones kept as starts (beyond the paper: §3.5(i) local maxima);
4. per start, ``em_iter`` EM iterations (:mod:`.em`) then L-BFGS-B on the exact likelihood
   (:mod:`.mle`; beyond the paper: EM's slow convergence); the best likelihood wins;
5. standard errors and 95 % intervals from the observed information (§3.4), in physical units;
6. recording-length advice from the per-sample information.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .. import kalman
from ..errors import InputError
from ..kalman import statespace as ss
from ..noise.components import COMPONENT_TYPES, RR, Component, total_allan_variance
from ..noise.modelspec import model_name, parse_model, parse_structure
from . import em, mle, starts, whittle

#: Two-sided 95 % normal quantile.
Z95 = 1.959963984540054
#: Smallest number of observed samples accepted, and per free parameter.
MIN_SAMPLES, MIN_SAMPLES_PER_PARAMETER = 100, 20
#: Above this standard error in log space (a 95 % Wald interval wider than ×7 each way) the Wald interval is
#: replaced by a likelihood-ratio one (:func:`imu_noise_id.core.estimation.mle.likelihood_interval`).
WALD_MAX_SE_LOG = 1.0
#: Above this length a record with missing samples is searched gap-filled first (see fit_model).
FILL_FIRST_MIN_SAMPLES = 20_000
#: Default candidate structures of :func:`select_model` (RR / QN added when the AV suggests them).
DEFAULT_CANDIDATES: tuple[str, ...] = ("WN+RW", "WN+GM", "WN+GM+RW", "WN+2GM")


def parameter_labels(components: list[Component]) -> list[tuple[int, str, str]]:
    """(component index, parameter, label) with labels such as ``WN.noise_density``, ``GM2.tau``."""
    names = [c.name for c in components]
    out = []
    seen: dict[str, int] = {}
    for i, c in enumerate(components):
        seen[c.name] = seen.get(c.name, 0) + 1
        tag = f"{c.name}{seen[c.name]}" if names.count(c.name) > 1 else c.name
        out.extend((i, p, f"{tag}.{p}") for p in c.parameter_names)
    return out


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
        physical units. Intervals of positive parameters are exp(log-value ± 1.96·se_log) (asymmetric); where
        se_log > 1 or a thousandfold smaller value is not rejected by the data (weakly identified, e.g. a variance
        near 0), a likelihood-ratio interval conditional on the other parameters is given instead, with lower
        end 0 when the data cannot exclude 0.
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
    information_ok : bool
        Whether the observed information was positive definite (else some se are inf: not identified).
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
    n_eval: int = 0
    n_params: int = 0
    starts: list[float] = field(default_factory=list)
    statespace: ss.StateSpace | None = field(default=None, repr=False)
    _y: np.ndarray | None = field(default=None, repr=False)
    _z: np.ndarray | None = field(default=None, repr=False)

    def without_data(self) -> FitResult:
        """This result without the record it was fitted to (two arrays of N floats), for keeping many results.

        :meth:`standardized_innovations` needs the record and raises on the copy; everything else works.
        """
        return replace(self, _y=None, _z=None)

    def standardized_innovations(self) -> np.ndarray:
        """One-step innovations / √(their variance), NaN where the sample was missing."""
        if self.statespace is None or self._y is None:
            raise InputError("this FitResult holds no data to compute innovations from")
        res = kalman.loglik(self.statespace, self._y, self._z, profile_mean=False)
        return res.innovations / np.sqrt(res.variances)

    def theoretical_allan_variance(self, tau: np.ndarray) -> np.ndarray:
        """Allan variance [u²] of the fitted components at averaging times tau [s]."""
        return total_allan_variance(self.components, np.asarray(tau, dtype=float), self.dt)


def _check_signal(y: np.ndarray, dt: float) -> np.ndarray:
    if not (isinstance(dt, (int, float, np.floating)) and math.isfinite(dt) and dt > 0):
        raise InputError(f"sampling period dt must be a finite number > 0 s, got {dt!r}")
    y = np.asarray(y, dtype=float)
    if y.ndim != 1:
        raise InputError(f"the signal must be one axis (1-D), got shape {y.shape}")
    if np.any(np.isinf(y)):
        raise InputError("the signal contains infinite values; remove them or mark them as NaN (missing)")
    obs = np.isfinite(y)
    if not np.any(obs):
        raise InputError("the signal has no valid samples (all NaN)")
    if int(obs.sum()) < MIN_SAMPLES:
        raise InputError(f"the signal has {int(obs.sum())} valid samples; at least {MIN_SAMPLES} are needed")
    vals = y[obs]
    if np.ptp(vals) == 0.0:
        raise InputError("the signal is constant: there is no noise to identify (sensor stuck or wrong topic?)")
    return y


def _structure(structure: str | list[Component]) -> tuple[list[str], list[Component] | None]:
    if isinstance(structure, str):
        if "(" in structure:
            comps = parse_model(structure)
            return [c.name for c in comps], comps
        return parse_structure(structure), None
    comps = list(structure)
    if not comps or not all(isinstance(c, Component) for c in comps):
        raise InputError("structure must be a model string such as 'WN+GM+RW' or a list of Component objects")
    return [c.name for c in comps], comps


def _filled(y: np.ndarray) -> np.ndarray:
    obs = np.isfinite(y)
    if np.all(obs):
        return y
    idx = np.arange(y.size)
    return np.interp(idx, idx[obs], y[obs])


def _record_length(
    labels: list[str], cov: np.ndarray, comps: list[Component], n: int, dt: float, *, target: float
) -> RecordLengthAdvice:
    """Per-sample information = observed information / N, so se(T) = se(T_now)·√(T_now/T)."""
    t_now = n * dt
    needed, half, reliable = {}, {}, {}
    for k, lab in enumerate(labels):
        se_log = math.sqrt(cov[k, k]) if np.isfinite(cov[k, k]) and cov[k, k] >= 0 else math.inf
        half[lab] = Z95 * se_log
        needed[lab] = t_now * (Z95 * se_log / target) ** 2 if math.isfinite(se_log) else math.inf
        reliable[lab] = True
    for lab in labels:
        tag = lab.split(".")[0]
        if tag.startswith("GM"):
            gm = [c for c in comps if c.name == "GM"]
            idx = int(tag[2:]) - 1 if len(tag) > 2 else 0
            tau_c = gm[idx].params()["tau"]
            reliable[lab] = min(t_now, needed[lab]) >= 20.0 * tau_c
    return RecordLengthAdvice(target, "95 % two-sided, relative half-width", t_now, needed, half, reliable)


def _near_zero(par: mle.Parameterisation, res: mle.MLEResult, k: int, y: np.ndarray, z: np.ndarray) -> bool:
    """Whether shrinking parameter k a thousandfold lowers ℓ by less than the 95 % LR threshold (the data
    cannot tell it from 0, so a Wald interval in log space would be wrongly narrow)."""
    th = res.theta.copy()
    th[k] -= math.log(1e3)
    try:
        ll = kalman.loglik(par.to_model(th, res.model), y, z).loglik
    except (InputError, np.linalg.LinAlgError):
        return False
    return res.loglik - ll < mle.LR_DROP_95


def _one_start(
    start: list[Component], y: np.ndarray, z: np.ndarray, dt: float, *, exog_names: tuple[str, ...],
    em_iter: int, em_tol: float, polish: bool, tau_bounds: tuple[float, float], metric: np.ndarray | None,
) -> tuple[mle.MLEResult, int]:
    model = ss.from_components(start, dt, ramp="measurement", intercept=True, exog_names=exog_names)
    _, model, stats = kalman.profile_and_smooth(model, y, z)  # GLS means and the first E-step in one pass
    par = mle.Parameterisation.of(start)
    if polish:
        # The last EM iterate is scored by the quasi-Newton finish's first evaluation: no E-step for it here.
        run = em.run_em(model, y, z, max_iter=em_iter, tol=em_tol, initial=stats, final_estep=False)
        try:
            res = mle.maximise(par, run.model, y, z, tau_bounds=tau_bounds, metric=metric)
        except (InputError, np.linalg.LinAlgError):
            # That unscored update may have left the filter's domain: redo EM with the check, which keeps the
            # last good iterate (paper 000 §3.5(iii)).
            run = em.run_em(model, y, z, max_iter=em_iter, tol=em_tol, initial=stats)
            res = mle.maximise(par, run.model, y, z, tau_bounds=tau_bounds, metric=metric)
    else:
        run = em.run_em(model, y, z, max_iter=em_iter, tol=em_tol, initial=stats)
        prof = kalman.loglik(run.model, y, z)
        fitted = kalman.apply_beta(run.model, prof)
        theta = par.to_theta(ss.to_components(fitted))
        res = mle.MLEResult(theta, fitted, prof.loglik, 0, run.converged, "EM only", prof)
    return res, run.n_iter


def fit_model(
    y: np.ndarray,
    dt: float,
    structure: str | list[Component],
    *,
    exog: np.ndarray | None = None,
    exog_names: list[str] | None = None,
    init: list[Component] | None = None,
    drift: str | None = "em",
    n_starts: int = 3,
    em_iter: int = 3,
    em_tol: float = 1e-9,
    polish: bool = True,
    spectral_init: bool = True,
    uncertainty: bool = True,
    target_precision: float = 0.10,
) -> FitResult:
    """Fit one structure to one axis by maximum likelihood (EM then quasi-Newton), with CIs.

    Parameters
    ----------
    y
        Samples [u] at period ``dt`` [s]; NaN = missing (no update; the exact engine, a Python loop, is then
        used; for records longer than ``FILL_FIRST_MIN_SAMPLES`` the noise parameters are fitted on the record
        with its gaps linearly filled (fast engine) — an approximation that is negligible for a few isolated
        gaps — while the log-likelihood, mean parameters, innovations and intervals are exact with the gaps).
    structure
        ``'WN+GM+RW+RR'``, or a spec with values (``'WN(2e-4)+RW(3e-6)'``, used as the initial value), or
        a list of components (ditto).
    exog, exog_names
        (N, k) deterministic regressors of the measurement equation y_t = H x_t + B z_t + v_t and their names;
        B is estimated (GLS in the likelihood, closed form in the EM). Must be finite everywhere.
    init
        Initial components (same structure); default: from the structure string's values or the AV fit.
    drift
        With RR in the structure: ``'em'`` joint estimation (default), ``'ls'`` least-squares removal first
        (paper 000 §3.5(iii)); the noise parameters then come from the detrended record, and the slope reported
        is re-estimated by GLS with the fitted noise model (its OLS value is kept as ``ls_value``; the OLS
        standard error would assume white residuals). ``None`` forbids RR.
    n_starts
        Number of distinct starts tried (best likelihood kept).
    spectral_init
        Refine the AV-fit starts by the Whittle likelihood of the differences (:mod:`.whittle`)
        before ranking them, and precondition the quasi-Newton finish with the Whittle information (fast;
        beyond the paper).
    em_iter, em_tol
        EM iterations before the quasi-Newton finish, and the §3.5(ii) stopping threshold. A few EM steps are
        robust first steps from any start; the convergence itself is left to the quasi-Newton finish, which
        needs far fewer likelihood evaluations than EM's linear convergence (``polish=False`` and a large
        ``em_iter`` give the paper's pure EM).
    polish
        Finish with L-BFGS-B on the exact likelihood (``False``: EM only, as in the paper).
    uncertainty
        Compute the observed information, standard errors, intervals and the record-length advice.
    target_precision
        Relative 95 % half-width for the recording-length advice (0.10 = ±10 %).
    """
    y = _check_signal(y, dt)
    names, given = _structure(structure)
    ss.validate_structure(names)
    if init is not None:
        given = list(init)
        if [c.name for c in given] != names:
            raise InputError("init components do not match the structure")
    if given is not None:
        mle.Parameterisation.of(given).to_theta(given)  # positive, finite initial values
    has_rr = "RR" in names
    if has_rr and drift not in ("em", "ls"):
        raise InputError(f"structure has RR: drift must be 'em' or 'ls', got {drift!r}")
    if not 0 < target_precision < 1:
        raise InputError(f"target_precision must be in (0, 1), got {target_precision}")
    n_total = y.size
    obs = np.isfinite(y)
    n_obs = int(obs.sum())
    t = dt * np.arange(n_total)
    ls_slope = None
    fit_names = list(names)
    if has_rr and drift == "ls":
        A = np.column_stack([np.ones(n_obs), t[obs]])
        coef, *_ = np.linalg.lstsq(A, y[obs], rcond=None)
        resid = y[obs] - A @ coef
        s2 = float(resid @ resid) / max(n_obs - 2, 1)
        cov_ls = s2 * np.linalg.inv(A.T @ A)
        ls_slope = (float(coef[1]), math.sqrt(cov_ls[1, 1]))
        y = y - coef[1] * t
        fit_names = [n for n in names if n != "RR"]
        if given is not None:
            given = [c for c in given if c.name != "RR"]
    columns = [np.ones(n_total)]
    if "RR" in fit_names:
        columns.append(t)
    user_names: tuple[str, ...] = ()
    if exog is not None:
        exog = np.asarray(exog, dtype=float)
        if exog.ndim == 1:
            exog = exog[:, None]
        if exog.shape[0] != n_total:
            raise InputError(f"exog must have {n_total} rows (one per sample), got {exog.shape[0]}")
        user_names = tuple(exog_names or [f"exog{j}" for j in range(exog.shape[1])])
        if len(user_names) != exog.shape[1] or len(set(user_names)) != len(user_names):
            raise InputError("exog_names must give one distinct name per exog column")
        if set(user_names) & {"bias", "ramp"}:
            raise InputError("exog names 'bias' and 'ramp' are reserved")
        columns.extend(exog.T)
    z = np.column_stack(columns)
    n_free_noise = sum(len(COMPONENT_TYPES[n].parameter_names) for n in fit_names if n != "RR")
    n_params = n_free_noise + z.shape[1]
    if n_obs < MIN_SAMPLES_PER_PARAMETER * n_params:
        raise InputError(
            f"{n_obs} valid samples are too few for {n_params} parameters of {'+'.join(names)}; "
            f"record at least {MIN_SAMPLES_PER_PARAMETER * n_params} samples or choose a simpler model"
        )
    tau_bounds = (dt, 100.0 * n_total * dt)
    y_av = _filled(y)
    if "RR" in fit_names:
        A = np.column_stack([np.ones(n_total), t])
        y_av = y_av - A @ np.linalg.lstsq(A, y_av, rcond=None)[0]
    bp = whittle.banded_periodogram(y_av) if spectral_init else None
    if given is not None:
        start_values = [given]
    else:
        av = starts.empirical_allan(y_av, dt)
        fits = starts.fit_allan(fit_names, av, dt)
        if bp is not None:
            fits = sorted((whittle.whittle_fit(c, y_av, dt, bp) for _, c in fits), key=lambda r: -r[0])
            fits = starts.distinct([(-w, c) for w, c in fits], av.tau, dt)
        start_values = [c for _, c in fits[: max(n_starts, 1)]]
    # Long records with missing samples: the parameters are searched on the gap-filled record with the fast
    # engine (beyond the paper; the exact engine is a Python loop); likelihood, means, innovations and intervals
    # below are those of the record with its gaps.
    fill_first = n_obs < n_total and n_total > FILL_FIRST_MIN_SAMPLES and polish
    y_search = _filled(y) if fill_first else y
    best: tuple[mle.MLEResult, int] | None = None
    lls = []
    for start in start_values:
        try:
            metric = whittle.whittle_information(start, y_av, dt, bp) if bp is not None else None
            res = _one_start(
                start, y_search, z, dt, exog_names=user_names, em_iter=em_iter, em_tol=em_tol, polish=polish,
                tau_bounds=tau_bounds, metric=metric,
            )
        except (InputError, np.linalg.LinAlgError):
            continue
        lls.append(res[0].loglik)
        if best is None or res[0].loglik > best[0].loglik:
            best = res
    if best is None:
        raise InputError(f"no start of the {'+'.join(names)} fit gave a valid likelihood; try init=… values")
    res, n_iter = best
    model_ss = res.model
    comps = ss.to_components(model_ss)
    # The search's own profile at the optimum unless it ran on the gap-filled record.
    prof = res.profile if res.profile is not None and not fill_first else kalman.loglik(model_ss, y, z)
    se: dict[str, float] = {}
    ci: dict[str, tuple[float, float]] = {}
    exog_coef: dict[str, dict] = {}
    for name, value, var in zip(prof.names, prof.beta, np.diag(prof.beta_cov), strict=True):
        key = name.split(":", 1)[1]
        s_b = math.sqrt(max(float(var), 0.0))
        exog_coef[key] = {"value": float(value), "se": s_b, "ci95": (value - Z95 * s_b, value + Z95 * s_b)}
    if ls_slope is not None:
        # The OLS standard error assumes white residuals and is far too small with RW/GM noise: re-estimate
        # bias and slope by GLS on the original record with the fitted noise model (one closed-form step).
        y_orig = y + ls_slope[0] * t
        full = ss.from_components([*ss.to_components(model_ss), RR(ls_slope[0])], dt, exog_names=user_names)
        z_full = np.column_stack([z[:, :1], t, z[:, 1:]])
        gls = kalman.loglik(full, y_orig, z_full)
        k_ramp = gls.names.index("b:ramp")
        slope, s_b = float(gls.beta[k_ramp]), math.sqrt(max(float(gls.beta_cov[k_ramp, k_ramp]), 0.0))
        comps.append(RR(slope))
        k_bias = gls.names.index("b:bias")
        b0, s0 = float(gls.beta[k_bias]), math.sqrt(max(float(gls.beta_cov[k_bias, k_bias]), 0.0))
        exog_coef["bias"] = {"value": b0, "se": s0, "ci95": (b0 - Z95 * s0, b0 + Z95 * s0)}
        exog_coef["ramp"] = {"value": slope, "se": s_b, "ci95": (slope - Z95 * s_b, slope + Z95 * s_b),
                             "ls_value": ls_slope[0]}
    if "ramp" in exog_coef:
        rr_lab = next(lab for i, p, lab in parameter_labels(comps) if comps[i].name == "RR")
        se[rr_lab] = exog_coef["ramp"]["se"]
        ci[rr_lab] = exog_coef["ramp"]["ci95"]
    order = {n: i for i, n in enumerate(names)}
    comps = sorted(comps, key=lambda c: order.get(c.name, 99))
    k = n_free_noise + z.shape[1] + (1 if ls_slope is not None else 0)
    ll = float(prof.loglik)
    result = FitResult(
        model=model_name(comps), components=comps, exog_coef=exog_coef, se=se, ci95=ci, loglik=ll,
        aic=2 * k - 2 * ll, bic=k * math.log(n_obs) - 2 * ll, n=n_obs, dt=float(dt), n_iter=n_iter,
        converged=res.converged, n_eval=res.n_eval, n_params=k, starts=lls, statespace=model_ss, _y=y, _z=z,
    )
    return add_uncertainty(result, target_precision) if uncertainty else result


def add_uncertainty(fit: FitResult, target_precision: float = 0.10) -> FitResult:
    """Standard errors, 95 % intervals (§3.4) and the recording-length advice of a fit, in place.

    Observed information = minus the Hessian of the exact log-likelihood in log-parameters; Wald intervals
    in log space, likelihood-ratio ones where the parameter cannot be told from 0 or the information is flat.
    """
    if fit.statespace is None or fit._y is None:
        raise InputError("this FitResult holds no data to compute its uncertainty from")
    y, z, model_ss = fit._y, fit._z, fit.statespace
    comps_ss = ss.to_components(model_ss)
    par = mle.Parameterisation.of(comps_ss)
    theta = par.to_theta(comps_ss)
    res = mle.MLEResult(theta, model_ss, fit.loglik, 0, fit.converged, "")
    noise_labels = [lab for i, _, lab in parameter_labels(comps_ss) if not isinstance(comps_ss[i], RR)]
    info = mle.observed_information(par, theta, model_ss, y, z)
    cov, fit.information_ok = mle.covariance_from_information(info)
    for k, lab in enumerate(noise_labels):
        v = float(np.exp(theta[k]))
        s_log = math.sqrt(cov[k, k]) if np.isfinite(cov[k, k]) else math.inf
        fit.se[lab] = v * s_log
        zero = _near_zero(par, res, k, y, z)
        if s_log <= WALD_MAX_SE_LOG and not zero:
            fit.ci95[lab] = (v * math.exp(-Z95 * s_log), v * math.exp(Z95 * s_log))
        else:
            lo, hi = mle.likelihood_interval(par, theta, k, model_ss, y, z=z, ll_max=fit.loglik, lower=not zero)
            fit.ci95[lab] = (math.exp(lo) if math.isfinite(lo) else 0.0,
                             math.exp(hi) if math.isfinite(hi) else math.inf)
    fit.record_length = _record_length(noise_labels, cov, comps_ss, fit.n, fit.dt, target=target_precision)
    return fit


@dataclass
class SelectionResult:
    """Model selection of one axis: the winner and the evidence."""

    best: FitResult
    table: list[dict]  # per candidate: model, loglik, k, aic, bic, delta_bic, weight_bic, delta_aic, error
    fits: dict[str, FitResult]

    def without_data(self) -> SelectionResult:
        """The selection with every fit's record dropped (see :meth:`FitResult.without_data`)."""
        fits = {k: f.without_data() for k, f in self.fits.items()}
        best = next((fits[k] for k, f in self.fits.items() if f is self.best), self.best.without_data())
        return SelectionResult(best, self.table, fits)


def suggest_candidates(y: np.ndarray, dt: float) -> list[str]:
    """Default candidates plus RR when the AV rises like τ² at long τ, QN when it falls like τ⁻² at short τ."""
    cands = list(DEFAULT_CANDIDATES)
    av = starts.empirical_allan(_filled(np.asarray(y, dtype=float)), dt)
    if av.tau.size >= 4:
        slope_hi = np.polyfit(np.log(av.tau[-3:]), np.log(av.avar[-3:]), 1)[0]
        slope_lo = np.polyfit(np.log(av.tau[:3]), np.log(av.avar[:3]), 1)[0]
        if slope_hi > 1.5:
            cands += ["WN+RW+RR", "WN+GM+RW+RR"]
        if slope_lo < -1.4:
            cands += ["WN+QN+RW", "WN+QN+GM"]
    return cands


def select_model(
    y: np.ndarray, dt: float, candidates: list[str] | None = None, *, criterion: str = "bic", **fit_kwargs
) -> SelectionResult:
    """Fit every candidate structure and rank them by BIC (or AIC); ΔBIC and Schwarz weights as evidence.

    Standard errors and the recording-length advice are computed for the winner only (unless
    ``uncertainty=False``); :func:`add_uncertainty` adds them to any other fit of ``fits``.
    """
    if criterion not in ("bic", "aic"):
        raise InputError(f"criterion must be 'bic' or 'aic', got {criterion!r}")
    y = _check_signal(y, dt)
    cands = list(candidates) if candidates else suggest_candidates(y, dt)
    fits: dict[str, FitResult] = {}
    errors: dict[str, str] = {}
    uncertainty = fit_kwargs.pop("uncertainty", True)
    target = fit_kwargs.get("target_precision", 0.10)
    best_key: str | None = None
    for spec in cands:
        try:
            fit = fit_model(y, dt, spec, uncertainty=False, **fit_kwargs)
        except InputError as exc:
            errors[spec] = str(exc)
            continue
        # Only the current best keeps its record (N floats per array): memory stays bounded on long records.
        if best_key is None or getattr(fit, criterion) < getattr(fits[best_key], criterion):
            if best_key is not None:
                fits[best_key] = fits[best_key].without_data()
            best_key = spec
        else:
            fit = fit.without_data()
        fits[spec] = fit
    if best_key is None:
        raise InputError("no candidate model could be fitted: " + "; ".join(f"{k}: {v}" for k, v in errors.items()))
    bic_min = min(f.bic for f in fits.values())
    aic_min = min(f.aic for f in fits.values())
    wsum = sum(math.exp(-0.5 * (f.bic - bic_min)) for f in fits.values())
    table = []
    for spec in cands:
        if spec in fits:
            f = fits[spec]
            table.append({
                "model": f.model, "loglik": f.loglik, "k": f.n_params, "aic": f.aic, "bic": f.bic,
                "delta_bic": f.bic - bic_min, "delta_aic": f.aic - aic_min,
                "weight_bic": math.exp(-0.5 * (f.bic - bic_min)) / wsum, "converged": f.converged,
            })
        else:
            table.append({"model": spec, "error": errors[spec]})
    table.sort(key=lambda r: r.get(criterion, math.inf))
    if uncertainty:
        add_uncertainty(fits[best_key], target)
    return SelectionResult(fits[best_key], table, fits)


def simulate_allan_band(
    fit: FitResult, n: int, tau: np.ndarray | None = None, n_sim: int = 20, seed: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """AVs of ``n_sim`` simulations (n samples each) of the fitted model (paper 000 figs. 4, 6, 7).

    Returns (tau, avar) with avar of shape (n_sim, len(tau)); tau defaults to octaves up to n·dt/4.
    """
    from ..noise.components import simulate_sum

    rng = np.random.default_rng(seed)
    out = []
    taus = None
    for _ in range(n_sim):
        sim = simulate_sum(fit.components, n, fit.dt, rng)
        av = starts.empirical_allan(sim, fit.dt)
        if tau is None:
            taus = av.tau
            out.append(av.avar)
        else:
            taus = np.asarray(tau, dtype=float)
            out.append(np.interp(np.log(taus), np.log(av.tau), av.avar))
    return taus, np.array(out)


def kalibr_values(fit: FitResult) -> dict[str, float | None]:
    """Kalibr ``imu.yaml`` values from a fitted model: ``noise_density`` [u/√Hz] from WN and ``random_walk``
    [u/s/√Hz] from RW (None when the model has no RW: its long-term error is then a GM or a ramp, which Kalibr's
    model cannot express; the caller keeps the Allan-slope value beside it)."""
    wn = next((c for c in fit.components if c.name == "WN"), None)
    rw = next((c for c in fit.components if c.name == "RW"), None)
    return {
        "noise_density": wn.params()["noise_density"] if wn else None,
        "random_walk": rw.params()["random_walk"] if rw else None,
    }
