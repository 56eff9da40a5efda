"""Adjusted profile-likelihood intervals (core/estimation/profile.py) against an independent maximisation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize

from imu_noise_id.core import kalman
from imu_noise_id.core.estimation.em import mle, profile
from imu_noise_id.core.estimation.em.model import FitOptions, fit_model
from imu_noise_id.core.estimation.em.profile import adjusted
from imu_noise_id.core.kalman import statespace as ss
from imu_noise_id.core.noise.components import GM, RR, RW, WN, simulate_sum

#: Issue 12's mix: a GM whose τ is not small against the 1 h record, beside a random walk near 0 and a ramp.
TRUTH = [WN(1e-3), GM(tau=100.0, sigma=3e-4), RW(1e-5), RR(1e-7)]
CHI2_1_95 = 3.841458820694124


def _lr_at(fit, name: str, param: str, value: float) -> float:
    """2(ℓ_A at the fit − max ℓ_A with ``name.param`` held at ``value``), the other log-parameters maximised by
    Nelder–Mead from the fit with its random walk at the truth's: a search that shares nothing with the Profiler's
    but the likelihood. (Started from a ladder of random walks 1e-7 … 1e-4 every start reached the same 0.90 at
    τ = 100 s, in five times the time; fewer starts can only raise the value, so the premise stays conservative.)"""
    (y, z), model = fit.record, fit.statespace
    comps = ss.to_components(model)
    par = mle.Parameterisation.of(comps)
    theta = par.to_theta(comps)
    k = next(j for j, (i, p) in enumerate(par.entries) if par.template[i].name == name and p == param)
    k_rw = next(j for j, (i, _) in enumerate(par.entries) if par.template[i].name == "RW")
    free = [j for j in range(theta.size) if j != k]

    def minus_adjusted(x: np.ndarray) -> float:
        th = theta.copy()
        th[k], th[free] = math.log(value), x
        try:
            return -adjusted(kalman.loglik(par.to_model(th, model), y, z))
        except (ValueError, np.linalg.LinAlgError):
            return math.inf

    a_fit = adjusted(kalman.loglik(model, y, z))
    x0 = theta[free].copy()
    x0[free.index(k_rw)] = math.log(next(c.random_walk for c in TRUTH if isinstance(c, RW)))
    res = minimize(minus_adjusted, x0, method="Nelder-Mead", options={"xatol": 1e-3, "fatol": 1e-3, "maxfev": 300})
    return 2.0 * (a_fit + res.fun)


def test_gm_tau_interval_keeps_a_value_the_adjusted_profile_keeps():
    """Issue 12, seed 1027 of bench_coverage's WN+GM+RW+RR: the fit takes the long-τ branch (τ̂ 217 s, K̂ ≈ 0);
    with τ held at the true 100 s the maximum has K back near its truth, within 1.92 of the fit's ℓ_A. The
    interval was [117 s, ∞): the inner maximisations never left K ≈ 0."""
    y = simulate_sum(TRUTH, 36_000, 0.1, np.random.default_rng(1027)) + 0.1
    fit = fit_model(y, 0.1, "WN+GM+RW+RR", options=FitOptions(n_starts=2))
    assert _lr_at(fit, "GM", "tau", 100.0) < CHI2_1_95  # the premise: the true τ is inside the LR set
    lo, hi = fit.ci95["GM.tau"]
    assert fit.ci95_method["GM.tau"] == "profile"
    assert lo <= 100.0 <= hi


def test_observed_information_at_an_oscs_damping_bound_steps_back_into_its_domain():
    """An OSC fitted at ζ = MAX_DAMPING (a broad low-pass hump): a forward step in ln B would leave the domain and
    raise. The information then takes the backward difference, equal to the central one of an interior point
    nearby within the finite-difference error."""
    from imu_noise_id.core.noise.components import OSC
    from imu_noise_id.core.noise.resonant import MAX_DAMPING

    dt = 0.01
    at_bound = [WN(3.5e-3), OSC(10.0, 2.0 * MAX_DAMPING * 10.0, 0.02)]
    y = simulate_sum(at_bound, 4000, dt, np.random.default_rng(5))
    z = np.ones((y.size, 1))  # the intercept
    par = mle.Parameterisation.of(at_bound)
    theta = par.to_theta(at_bound)
    model = ss.from_components(at_bound, dt)
    info = mle.observed_information(par, theta, model, y, z)
    inside = theta.copy()
    inside[2] -= 2e-3  # ln B just inside the bound
    reference = mle.observed_information(par, inside, model, y, z, central=True)
    assert np.all(np.isfinite(info))
    np.testing.assert_allclose(info, reference, rtol=0.05, atol=0.05 * np.abs(np.diag(reference)).max())


def test_repeated_starts_are_evaluated_once_and_the_intervals_do_not_change():
    """A profile point of a zero-boundary parameter gets a ladder of starts in that parameter, which the point's
    value then overwrites: every rung is the same start. Screening each repeat cost a likelihood evaluation (393
    instead of 343 on bench_em's 1 h record); the intervals are the same without the repeats."""
    y = simulate_sum([WN(1e-3), GM(tau=5.0, sigma=1e-3), RW(3e-6), RR(1e-6)], 20_000, 0.1,
                     np.random.default_rng(3)) + 2e-3
    repeated = [np.array([1.0, 2.0]), np.array([1.0, 2.0]), np.array([1.0, 3.0]), np.array([1.0, 2.0])]
    assert [s.tolist() for s in profile.distinct(repeated)] == [[1.0, 2.0], [1.0, 3.0]]
    fits = {}
    for label, keep_repeats in (("distinct", False), ("repeated", True)):
        with pytest.MonkeyPatch.context() as mp:
            if keep_repeats:
                mp.setattr(profile, "distinct", lambda starts: starts)
            fits[label] = fit_model(y, 0.1, "WN+GM+RW+RR", options=FitOptions(n_starts=1))
    assert fits["distinct"].ci95_method["RW.random_walk"] == "profile"  # the RW sits at its zero boundary
    assert fits["distinct"].ci95 == fits["repeated"].ci95
    assert fits["distinct"].profile_evaluations < fits["repeated"].profile_evaluations


def _ramp_fit_profiler():
    """(record, fit, parameterisation, ϑ̂, a Profiler of the fit with unit information and no bounds) of WN+GM+RW+RR
    fitted to 20 000 samples of it with the RW near 0."""
    y = simulate_sum([WN(1e-3), GM(tau=5.0, sigma=1e-3), RW(3e-6), RR(1e-6)], 20_000, 0.1,
                     np.random.default_rng(3)) + 2e-3
    fit = fit_model(y, 0.1, "WN+GM+RW+RR", options=FitOptions(n_starts=1))
    (yy, z), model = fit.record, fit.statespace
    comps = ss.to_components(model)
    par = mle.Parameterisation.of(comps)
    theta = par.to_theta(comps)
    k = theta.size
    return y, fit, par, theta, profile.Profiler(par, theta, model, yy, z, fit.loglik, np.eye(k), np.full(k, -np.inf),
                                                np.full(k, np.inf))


def test_a_held_slope_from_the_pass_with_every_mean_free_is_the_pass_with_it_held():
    """ℓ is quadratic in the means: ℓ and ℓ_A with the ramp's slope held at v, read from one pass with every mean
    free, equal a pass with the slope held, at several ϑ and v; the slope interval is the same as when every start is
    scored by its own pass, for fewer evaluations."""
    y, fit, _, theta, prof = _ramp_fit_profiler()
    model = fit.statespace
    j = model.regressors.index("ramp")
    for th in (theta, theta + np.linspace(-0.3, 0.3, theta.size)):
        for v in (-1e-5, 1e-6, 4e-6):
            held = model.copy()
            held.b_free[j], held.b[j] = False, v
            assert prof.held_mean(j, v)(th) == pytest.approx(prof.evaluate(th, held), abs=1e-6)
    # what is kept per ϑ is four numbers, not the pass's arrays (N floats each)
    assert all(np.ndim(x) == 0 for kept in prof._means_free.values() for x in kept)
    def one_pass_each(self, j, v):
        held = self.model.copy()
        held.b_free[j], held.b[j] = False, v
        return lambda th: self.evaluate(th, held)

    fits = {}
    for label, closed in (("held", True), ("passes", False)):
        with pytest.MonkeyPatch.context() as mp:
            if not closed:
                mp.setattr(profile.Profiler, "held_mean", one_pass_each)
            fits[label] = fit_model(y, 0.1, "WN+GM+RW+RR", options=FitOptions(n_starts=1))
    assert fits["held"].ci95_method["RR.slope"] == "profile"
    np.testing.assert_allclose(fits["held"].ci95["RR.slope"], fits["passes"].ci95["RR.slope"], rtol=1e-6)
    assert fits["held"].profile_evaluations < fits["passes"].profile_evaluations


def test_a_scored_start_gives_its_adjustment_without_another_pass():
    """½ log det cov(b̂) does not depend on the data: ℓ_A − ℓ of a start's scoring pass is the adjustment a pass on
    zeros gives, so the inner maximisation takes it from there and spends one pass fewer."""
    _, fit, par, theta, prof = _ramp_fit_profiler()
    model = fit.statespace
    k_rw = next(j for j, (i, _) in enumerate(par.entries) if par.template[i].name == "RW")
    for th in (theta, theta + 0.2):
        ll, a = prof.evaluate(th, model)
        assert a - ll == pytest.approx(prof.adjustment(th, model), abs=1e-9)
    prof.zero = {k_rw: 1e-4}
    zeros_passes = []
    with pytest.MonkeyPatch.context() as mp:
        counted = profile.Profiler.adjustment
        mp.setattr(profile.Profiler, "adjustment",
                   lambda self, th, base: zeros_passes.append(1) or counted(self, th, base))
        starts = prof.with_ladder(theta)
        prof.maximise(starts, set(range(theta.size)) - {k_rw}, model)
    # the adjustment's gradient at the estimate (1 + k passes, once per mask) and the RW's step: not the start's
    assert len(zeros_passes) == 1 + theta.size + 1


def test_the_curvature_along_a_ladders_rungs_is_the_parabolas():
    """rung_curvature: −ℓ_A'' of a parabola through the best rung and its neighbours, exactly; NaN where the best rung
    is the last on either side or ℓ_A does not bend there."""
    rungs = [(x, 3.0 - 2.5 * (x - 0.7) ** 2) for x in (0.05, 0.14, 0.37, 1.0, 2.7)]
    assert profile.rung_curvature(rungs) == pytest.approx(5.0)
    assert profile.rung_curvature(list(reversed(rungs))) == pytest.approx(5.0)
    assert math.isnan(profile.rung_curvature([(x, -x) for x in (0.1, 0.4, 1.0)]))  # best at the first rung
    assert math.isnan(profile.rung_curvature([(x, x) for x in (0.1, 0.4, 1.0)]))  # best at the last
    assert math.isnan(profile.rung_curvature([(0.1, 1.0), (0.4, 1.0), (1.0, 1.0)]))


def test_a_boundary_parameters_search_coordinate_is_scaled_by_the_curvature_along_its_rungs():
    """L-BFGS-B's first step assumes a unit Hessian; where a long record pins K down, −ℓ_A'' of a zero-boundary
    parameter's K/s is far above 1 and that step overshot (docs/em.md). The coordinate handed to it is K/s·√c, c the
    curvature of ℓ_A along the scored starts' rungs (computed here from passes of our own), where c > 1; below 1 it is
    K/s as before. Its start and bounds say so."""
    _, fit, par, theta, prof = _ramp_fit_profiler()
    k_rw = next(j for j, (i, _) in enumerate(par.entries) if par.template[i].name == "RW")
    s = prof.conditional_scale(k_rw)
    model = fit.statespace
    start = theta + 0.05
    inner = profile.minimize

    def handed(scale: float) -> tuple[list[tuple[float, float]], float, tuple[float, float]]:
        """(the rungs' (K/scale, ℓ_A), and the start and bounds of K's coordinate handed to L-BFGS-B) with the
        boundary parameter's scale at ``scale``."""
        prof.zero = {k_rw: scale}
        rungs = [(math.exp(t[k_rw]) / scale, prof.evaluate(t, model)[1]) for t in prof.with_ladder(start)]
        seen = []
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(profile, "minimize",
                       lambda fun, x0, **kw: seen.append((x0, kw["bounds"])) or inner(fun, x0, **kw))
            prof.maximise(prof.with_ladder(start), set(range(theta.size)) - {k_rw}, model)
        (x0, bounds), = seen
        return rungs, x0[0], bounds[0]

    rungs, x0, bounds = handed(s)
    c = profile.rung_curvature(rungs)
    assert c > 1.0  # scaled only where ℓ_A bends faster than the unit Hessian L-BFGS-B starts from
    w = math.sqrt(c)
    assert x0 == pytest.approx(max(rungs, key=lambda p: p[1])[0] * w)
    assert bounds == pytest.approx((profile.ZERO_FLOOR * w, profile.ZERO_CAP * w))
    # measured against two thirds of the scale, ℓ_A bends 4/9 as fast in K/s: below 1, K/s is left as it is
    rungs, _, bounds = handed(s / 1.5)
    assert profile.rung_curvature(rungs) < 1.0
    assert bounds == pytest.approx((profile.ZERO_FLOOR, profile.ZERO_CAP))
