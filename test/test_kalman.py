"""State-space assembly and the Kalman engines: fast path = exact recursion = statsmodels; missing samples."""

from __future__ import annotations

import contextlib
import warnings

import numpy as np
import pytest
from kalman_checks import assert_state_sums_close

from imu_noise_id.core import kalman
from imu_noise_id.core.errors import InputError
from imu_noise_id.core.estimation.em import mle
from imu_noise_id.core.kalman import basis, common, riccati
from imu_noise_id.core.kalman import statespace as ss
from imu_noise_id.core.kalman.riccati import SteadyCovarianceSensitivity, steady_prediction_covariance
from imu_noise_id.core.noise.components import GM, OSC, QN, RR, RW, WN, simulate_sum
from imu_noise_id.core.noise.flicker import BI

MIXES = {
    "WN+RW+RR": [WN(0.2), RW(0.02), RR(1e-3)],
    "WN+GM+RW+RR": [WN(0.3), GM(tau=20.0, sigma=0.5), RW(0.01), RR(1e-3)],
    "WN+2GM": [WN(0.3), GM(tau=5.0, sigma=0.4), GM(tau=200.0, sigma=0.2)],
    "WN+QN+GM": [WN(0.3), QN(0.2), GM(tau=30.0, sigma=0.3)],
}


def _data(components, n, dt=1.0, seed=0, bias=1.5):
    rng = np.random.default_rng(seed)
    y = simulate_sum(components, n, dt, rng) + bias
    model = ss.from_components(components, dt)
    z = np.column_stack([np.ones(n), dt * np.arange(n)])[:, : model.n_regressors]
    return model, y, z


def test_assembly_masks_and_round_trip():
    comps = [WN(0.3), GM(tau=20.0, sigma=0.5), RW(0.01), RR(1e-3)]
    m = ss.from_components(comps, 0.5)
    assert m.n_states == 2 and m.regressors == ("bias", "ramp")
    f, D = m.design("phi")  # vec(Φ) = f + D m: only the GM transition is free
    assert D.shape == (4, 1) and f[3] == 1.0 and f[0] == 0.0
    assert np.allclose(f + D @ m.free_values("phi"), m.phi.flatten(order="F"))
    back = ss.to_components(m)
    for a, b in zip(comps, back, strict=True):
        for k, v in a.params().items():
            assert b.params()[k] == pytest.approx(v, rel=1e-10)


def test_paper_state_mode_puts_ramp_into_rw_state():
    m = ss.from_components([WN(0.2), GM(tau=100.0, sigma=0.5), RW(0.02), RR(1e-4)], 1.0, ramp="state")
    assert m.u_free.tolist() == [False, True] and m.u[1] == pytest.approx(1e-4)
    m2 = ss.from_components([WN(0.2), GM(tau=100.0, sigma=0.5), RR(1e-3)], 1.0, ramp="state")
    assert m2.u_free.tolist() == [True]


@pytest.mark.parametrize("structure", ["WN", "RW", "WN+WN+RW"])
def test_unidentifiable_structures_are_rejected(structure):
    comps = {"WN": [WN(0.1)], "RW": [RW(0.1)], "WN+WN+RW": [WN(0.1), WN(0.2), RW(0.1)]}[structure]
    if structure == "WN":
        assert ss.from_components(comps, 1.0).n_states == 0
        return
    with pytest.raises(InputError):
        ss.from_components(comps, 1.0)


@pytest.mark.parametrize("name", list(MIXES))
def test_fast_path_equals_exact_recursion(name):
    model, y, z = _data(MIXES[name], 2000)
    r_exact = kalman.loglik(model, y, z, engine="exact")
    r_fast = kalman.loglik(model, y, z, engine="steady")
    assert r_fast.loglik == pytest.approx(r_exact.loglik, abs=1e-8)
    np.testing.assert_allclose(r_fast.beta, r_exact.beta, rtol=1e-9)
    fitted = kalman.apply_beta(model, r_fast)
    s_exact = kalman.smooth(fitted, y, z, engine="exact")
    s_fast = kalman.smooth(fitted, y, z, engine="steady")
    for key in ("sum_p", "p_first", "p_last", "sum_lag"):
        a, b = getattr(s_exact, key), getattr(s_fast, key)
        np.testing.assert_allclose(b, a, rtol=1e-8, atol=1e-10 * np.max(np.abs(a)), err_msg=key)
    assert_state_sums_close(s_fast.states, s_exact.states, y, z, rtol=1e-8, atol_rel=1e-10)
    assert s_fast.loglik == pytest.approx(s_exact.loglik, abs=1e-8)


def _statsmodels_loglik(model, y, z, sigma):
    from statsmodels.tsa.statespace.mlemodel import MLEModel

    p = model.n_states
    mod = MLEModel(y, k_states=p)
    mod.ssm["design"] = model.h.reshape(1, p)
    mod.ssm["obs_intercept"] = (z @ model.b).reshape(1, -1)
    mod.ssm["obs_cov"] = np.array([[model.r]])
    mod.ssm["transition"] = model.phi
    mod.ssm["state_intercept"] = model.u.reshape(p, 1)
    mod.ssm["selection"] = np.eye(p)
    mod.ssm["state_cov"] = model.q
    mod.ssm.initialize_known(model.mu, sigma)
    return float(mod.ssm.loglike())


@pytest.mark.parametrize("sigma_mode", ["steady", "fixed"])
@pytest.mark.parametrize("name", ["WN+GM+RW+RR", "WN+2GM"])
def test_exact_loglik_equals_statsmodels(name, sigma_mode):
    model, y, z = _data(MIXES[name], 1500, seed=3)
    model = model.copy(sigma_mode=sigma_mode, mu=np.full(model.n_states, 0.05))
    model.b[:] = [1.2, 2e-3][: model.n_regressors]
    model.u[-1] = 1e-4
    y[[10, 500, 501]] = np.nan
    ours = kalman.loglik(model, y, z, profile_mean=False).loglik
    theirs = _statsmodels_loglik(model, y, z, model.initial_covariance())
    assert ours == pytest.approx(theirs, abs=1e-7)


def test_missing_samples_are_skipped_not_filled():
    model, y, z = _data(MIXES["WN+GM+RW+RR"], 800, seed=5)
    y_gap = y.copy()
    y_gap[100:110] = np.nan
    r = kalman.loglik(model, y_gap, z)
    assert np.all(np.isnan(r.innovations[100:110])) and np.all(np.isfinite(r.innovations[110:]))
    # The likelihood of the remaining samples differs from that of the complete record.
    assert r.loglik != pytest.approx(kalman.loglik(model, y, z).loglik)
    with pytest.raises(InputError):
        kalman.loglik(model, y_gap, z, engine="steady")
    y_bad = y.copy()
    y_bad[3] = np.inf
    with pytest.raises(InputError):
        kalman.loglik(model, y_bad, z)


@contextlib.contextmanager
def _riccati_solves():
    """The guess of every Riccati solve a StateSpace asks for while the block runs, listed."""
    guesses: list[np.ndarray | None] = []
    solve = ss.steady_prediction_covariance
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(ss, "steady_prediction_covariance",
                   lambda *args, guess=None: guesses.append(guess) or solve(*args, guess=guess))
        yield guesses


@pytest.mark.parametrize("name", list(MIXES))
@pytest.mark.parametrize("rel_step", [1e-6, 0.3])
def test_newton_riccati_from_a_nearby_model_equals_doubling(name, rel_step):
    # A copy solves its DARE by Newton from the original's P̄; it must agree with the doubling from scratch to
    # the ~1e-13 relative rounding floor of its Stein sums (1e-11 leaves margin for poles near 1).
    model = ss.from_components(MIXES[name], 1.0)
    model.steady_prediction_covariance()
    comps = [c if isinstance(c, RR) else type(c)(**{k: v * (1 + rel_step) for k, v in c.params().items()})
             for c in MIXES[name]]
    moved = ss.with_components(model, comps)
    reference = steady_prediction_covariance(moved.phi, moved.q, moved.h, moved.r)
    with _riccati_solves() as guesses:
        got = moved.steady_prediction_covariance()
    assert len(guesses) == 1 and guesses[0] is not None  # the warm start is actually used
    np.testing.assert_allclose(got, reference, rtol=0, atol=1e-11 * np.max(np.abs(reference)))


def test_a_copy_with_other_means_keeps_the_riccati_solution():
    """The GLS profile returns the model with its means: the same Φ, Q, H, R, so P̄ is not solved again (it had been,
    by a Newton step, for every gradient's initial-state term); a copy with another Q is solved, from P̄."""
    model = ss.from_components(MIXES["WN+GM+RW+RR"], 1.0)
    solved = model.steady_prediction_covariance()
    with _riccati_solves() as calls:
        same = model.copy(b=model.b + 1.0, mu=model.mu + 2.0).steady_prediction_covariance()
        assert not calls
        np.testing.assert_array_equal(same, solved)
        assert same is not solved  # a copy: neither model's P̄ changes with the other's
        other = model.copy(q=2.0 * model.q).steady_prediction_covariance()
    assert len(calls) == 1 and calls[0] is not None
    np.testing.assert_allclose(other, steady_prediction_covariance(model.phi, 2.0 * model.q, model.h, model.r),
                               rtol=0, atol=1e-11 * np.max(np.abs(other)))



@pytest.mark.parametrize("walk_scale", [1e3, 1.0 + 1e-3])
def test_newton_riccati_from_a_guess_decades_away_gives_way_to_the_doubling_after_one_step(walk_scale):
    """A warm start whose walk variance is decades off (a fit's start, a profile point): Newton's steps only about
    halve the error there (19 steps), so after a first step that moves a variance by more than NEWTON_FAR it stops
    and the doubling solves; from a nearby guess Newton finishes alone. P̄ is the doubling's either way."""
    model = ss.from_components([WN(0.3), GM(tau=20.0, sigma=0.5), RW(1e-6)], 1.0)
    reference = steady_prediction_covariance(model.phi, model.q, model.h, model.r)
    guess = reference.copy()
    guess[-1, -1] *= walk_scale
    calls = {"_stein_sum": 0, "_doubling_dare": 0}

    def counted(name):
        plain = getattr(riccati, name)

        def spy(*args, **kwargs):
            calls[name] += 1
            return plain(*args, **kwargs)
        return spy

    with pytest.MonkeyPatch.context() as mp:
        for name in calls:
            mp.setattr(riccati, name, counted(name))
        got = steady_prediction_covariance(model.phi, model.q, model.h, model.r, guess=guess)
    far = walk_scale > 2.0
    assert calls["_doubling_dare"] == int(far) and (calls["_stein_sum"] == 1 or not far)
    np.testing.assert_allclose(got, reference, rtol=0, atol=1e-11 * np.max(np.abs(reference)))


@pytest.mark.parametrize("direction", ["phi", "q", "h", "r"])
def test_the_steady_covariance_sensitivity_equals_finite_differences_of_the_doubling(direction):
    # tr(W dP̄) from the adjoint Stein solve against central differences of P̄ solved from scratch by the doubling
    # (no shared code but the DARE's definition), along a random direction in each model matrix.
    rng = np.random.default_rng(7)
    phi = np.diag([0.95, 0.9, 0.8, 0.5, 0.7])
    phi[1, 2] = 0.05
    q, h, r = np.diag([0.1, 0.1, 0.01, 0.1, 0.2]), np.array([1.0, 1.0, 0.5, 1.0, 1.0]), 0.3
    W = rng.standard_normal((5, 5))
    W = W + W.T
    step = {"phi": rng.standard_normal((5, 5)) * (phi != 0) * 1e-3, "q": np.diag(rng.random(5)) * 1e-4,
            "h": rng.standard_normal(5) * 1e-2, "r": 0.01}[direction]

    def moved(e: float) -> dict:
        mats = {"phi": phi, "q": q, "h": h, "r": r}
        mats[direction] = mats[direction] + e * step
        return mats

    sensitivity = SteadyCovarianceSensitivity.of(phi, q, h, r, P=steady_prediction_covariance(phi, q, h, r), W=W)
    eps = 1e-6
    numeric = (np.vdot(W, steady_prediction_covariance(**moved(eps)))
               - np.vdot(W, steady_prediction_covariance(**moved(-eps)))) / (2 * eps)
    gradient = {"phi": sensitivity.g_phi, "q": sensitivity.g_q, "h": sensitivity.g_h, "r": sensitivity.g_r}[direction]
    assert np.vdot(gradient, step) == pytest.approx(numeric, rel=1e-5)


@pytest.mark.parametrize("walk", [1e-8, 1e-11, 1e-13])
def test_a_walk_far_below_the_other_states_is_solved_to_its_own_scale(walk):
    """A random walk driven far below a GM and a white noise (a walk the fit collapsed, 100 Hz): the DARE holds entry by
    entry to the scale of the entries' own states, from scratch and by Newton from a nearby P̄. The doubling and the
    sums stopped on the largest entry's scale, the GM's; a walk of 1e-11 then got P̄ 2e-21 where it is
    ~√(q r) = 1e-14, its gain was wrong and the score overflowed to 1e38."""
    model = ss.from_components([WN(1e-3), GM(tau=1.0, sigma=1e-3), RW(walk)], 0.01)
    phi, q, h, r = model.phi, model.q, model.h, float(model.r)
    scratch = steady_prediction_covariance(phi, q, h, r)
    newton = steady_prediction_covariance(phi, q, h, r, guess=scratch * 1.01)
    for P in (scratch, newton):
        gain = phi @ P @ h
        residual = phi @ P @ phi.T + q - np.outer(gain, gain) / (float(h @ P @ h) + r) - P
        states_scale = np.sqrt(np.outer(np.diag(P), np.diag(P)))
        assert np.all(np.abs(residual) <= 1e-8 * states_scale)
    assert np.sqrt(q[1, 1] * r) / 2 < scratch[1, 1] < 2 * np.sqrt(q[1, 1] * r)


#: The steady smoother's span settings: the record whole, or in spans of ~400 samples (the last shorter) reduced in
#: blocks of 256 (a block cut short at each span's end).
SPANS = {"whole": {}, "in spans": {"WHOLE_FLOATS": 0, "SPAN_FLOATS": 5000, "REDUCE_BLOCK": 256}}


@pytest.mark.parametrize("spans", list(SPANS))
def test_modal_and_schur_bases_give_the_exact_recursion(spans):
    """The steady engine's two bases (block-diagonal modal where well conditioned, Schur otherwise) against the exact
    time-varying recursion, on a model with a flicker ladder, two oscillators and regressor columns; the record
    smoothed whole and in spans (:func:`~imu_noise_id.core.kalman.steady._sweep`: the states of each span computed
    again from the state it starts in, the adjoint carried across the seams), the adjoint's sums too."""
    from imu_noise_id.core.kalman import steady
    from imu_noise_id.core.noise.components import BI
    from imu_noise_id.core.noise.resonant import LPF, OSC

    dt, n = 0.01, 3000
    comps = [WN(3e-3), LPF(noise_density=4e-3, cutoff=15.0), BI(4e-3, 0.1, n * dt),
             OSC(frequency=0.565, bandwidth=0.05, sigma=4e-3), OSC(frequency=10.7, bandwidth=0.45, sigma=8e-3),
             RW(2e-4)]
    rng = np.random.default_rng(5)
    t = dt * np.arange(n)
    exog = np.column_stack([np.sin(2 * np.pi * 0.7 * t), np.cos(2 * np.pi * 0.7 * t)])
    y = simulate_sum(comps, n, dt, rng) + 0.3 + exog @ [1e-3, -2e-3]
    model = ss.from_components(comps, dt, exog_names=["s", "c"])
    z = np.column_stack([np.ones(n), exog])
    assert steady.decoupled_basis(steady.gains(model).a).modal
    exact = kalman.loglik(model, y, z, engine="exact")
    fitted = kalman.apply_beta(model, exact)
    s_exact = kalman.smooth(fitted, y, z, engine="exact")
    for max_cond in (basis.MODAL_MAX_COND, 0.0):  # 0: every model falls back to the Schur basis
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(basis, "MODAL_MAX_COND", max_cond)
            for name, value in SPANS[spans].items():
                mp.setattr(steady, name, value)
            prof, _, stats = kalman.profile_and_smooth(model, y, z, engine="steady")
            s_fast = kalman.smooth(fitted, y, z, engine="steady")
        assert prof.loglik == pytest.approx(exact.loglik, abs=1e-7)
        np.testing.assert_allclose(prof.beta, exact.beta, rtol=1e-8)
        for s in (stats, s_fast):
            for key in ("sum_p", "sum_lag"):
                a, b = getattr(s_exact, key), getattr(s, key)
                np.testing.assert_allclose(b, a, rtol=1e-7, atol=1e-9 * np.max(np.abs(a)), err_msg=key)
            assert_state_sums_close(s.states, s_exact.states, y, z, rtol=1e-7, atol_rel=1e-9)
        assert s_fast.loglik == pytest.approx(s_exact.loglik, abs=1e-7)
        for key in ("rr", "rx", "n", "nlp"):
            a, b = getattr(s_exact.disturbances, key), getattr(s_fast.disturbances, key)
            np.testing.assert_allclose(b, a, rtol=1e-7, atol=1e-9 * np.max(np.abs(a)), err_msg=key)


def test_the_steady_smoothers_memory_does_not_grow_with_states_times_samples(monkeypatch):
    """Past :data:`~imu_noise_id.core.kalman.steady.WHOLE_FLOATS` the smoother holds p × span arrays, not p × N: on
    300 000 samples its peak (tracemalloc, the score's smoother) with 17 states exceeds that with 5 by less than a
    quarter of one 12 × N array (held whole, the difference is 60 MB, two such arrays). The test lowers the threshold
    to this record's size."""
    import tracemalloc

    from imu_noise_id.core.kalman import steady
    from imu_noise_id.core.noise.resonant import OSC

    dt, n = 0.01, 300_000
    monkeypatch.setattr(steady, "WHOLE_FLOATS", 1 << 20)
    y = simulate_sum([WN(1e-3), RW(1e-5)], n, dt, np.random.default_rng(3))
    z = np.ones((n, 1))
    peaks = []
    for oscillators in (1, 7):
        comps = [WN(1e-3), *(OSC(frequency=1.0 + 3 * k, bandwidth=0.5, sigma=1e-4) for k in range(oscillators)),
                 GM(tau=5.0, sigma=1e-4), RW(1e-5)]
        model = ss.from_components(comps, dt, exog_names=[])
        tracemalloc.start()
        kalman.profile_and_smooth(model, y, z, moments=False)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
    assert peaks[1] - peaks[0] < 0.25 * 12 * n * 8


def test_the_initial_state_as_the_filters_delay_state_gives_the_prepended_run_bit_for_bit():
    """:func:`blockfilter.strictly_proper` (the initial state w0 put into lfilter's delay state) against the run on the
    input with w0 prepended, the form it replaces: equal to the last bit, for 1st- and 2nd-order sections over
    several columns, whatever the sign of w0."""
    from scipy.signal import lfilter

    from imu_noise_id.core.kalman import blockfilter

    rng = np.random.default_rng(11)
    d = rng.standard_normal((3, 400))
    w0 = np.array([0.7, -1.3, 0.0])
    second = [1.0, -1.8, 0.85]
    for num, den in (((0.0, 1.0), [1.0, -0.97]), ((0.0, 1.0, -0.4), second), ((0.0, 0.0, 0.3), second)):
        prepended = lfilter(num, den, np.concatenate([w0[:, None], d], axis=1), axis=-1)[:, 1:]
        np.testing.assert_array_equal(blockfilter.strictly_proper(num, den, d, w0), prepended)


def test_a_blocks_output_filtered_once_per_row_equals_its_recursion():
    """:func:`blockfilter.driven_block` (one filter of the shared input per output row, the constants' step responses
    from the block's all-pole one) against x_0 = w0, x_{t+1} = B x_t + gain·y_t + const, rows c·x_t: for a 1×1 and
    a 2×2 block over several columns, with and without constant inputs and initial states."""
    from imu_noise_id.core.kalman import blockfilter

    rng = np.random.default_rng(12)
    n, m = 300, 3
    blocks = (np.array([[0.97]]), np.array([[0.95, 0.2], [-0.2, 0.95]]))
    for B in blocks:
        s = B.shape[0]
        for constant in (False, True):
            gain, y = rng.standard_normal(s), rng.standard_normal((m, n))
            const = rng.standard_normal((s, m)) * np.array([0.0, 1.0, -2.0]) * constant
            w0 = rng.standard_normal((s, m))
            c = rng.standard_normal((2, s))
            x = np.empty((s, m, n))
            x[:, :, 0] = w0
            for t in range(n - 1):
                x[:, :, t + 1] = B @ x[:, :, t] + gain[:, None] * y[:, t] + const
            expected = np.einsum("rs,smn->rmn", c, x)
            out = np.array(blockfilter.driven_block(B, c, gain, y, const=const, w0=w0))
            np.testing.assert_allclose(out, expected, rtol=1e-10, atol=1e-10 * np.max(np.abs(expected)))


def test_a_nearly_defective_transition_runs_in_the_schur_basis():
    from imu_noise_id.core.kalman import steady

    jordan = np.array([[0.9, 1.0], [0.0, 0.9 + 1e-12]])
    assert not steady.decoupled_basis(jordan).modal
    assert steady.decoupled_basis(np.diag([0.5, 0.9])).modal


@pytest.mark.parametrize("a", [
    np.array([[0.9, 1.0], [0.0, 0.9 + 1e-12]]),  # nearly defective: the Schur basis
    np.array([[0.95, 0.2, 0.1], [-0.2, 0.95, 0.0], [0.0, 0.0, 0.97]]),  # a complex pair and a real pole: modal
])
def test_the_smoothers_adjoint_in_either_basis_equals_its_backward_recursion(a):
    """:func:`steady._adjoint_span` run over spans from the record's end (each from the state the later one ended in)
    against r_{t−1} = Hᵀe_t/F + Aᵀr_t, r_{N−1} = 0, run plainly backwards."""
    from types import SimpleNamespace

    from imu_noise_id.core.kalman import steady

    p, n = a.shape[0], 60
    rng = np.random.default_rng(2)
    model, gains = SimpleNamespace(h=rng.standard_normal(p)), SimpleNamespace(f=0.7)
    e = rng.standard_normal(n)
    expected = np.zeros((p, n))  # column t: r_{t−1}
    r = np.zeros(p)
    for t in range(n - 1, -1, -1):
        r = model.h * e[t] / gains.f + a.T @ r
        expected[:, t] = r
    decoupled = steady.decoupled_basis(a)
    v = np.empty((p, n))  # column t: v_t = σ_{N−t}
    sigma = np.zeros(p)
    for s, stop in ((41, 60), (17, 41), (0, 17)):
        span, sigma = steady._adjoint_span(model, gains, decoupled, e[s:stop], sigma)
        v[:, s] = sigma
        v[:, s + 1:stop] = span[:, :0:-1]
    np.testing.assert_allclose(decoupled.u_inv.T @ v, expected, rtol=1e-9, atol=1e-12 * np.max(np.abs(expected)))


def test_where_the_doubling_ends_off_a_covariance_the_schur_method_solves_the_riccati_equation():
    """A GM of σ 305 beside a white noise of 8e-8 per sample (an optimiser's trial step reaches such ratios): the
    doubling ends on a P̄ with an eigenvalue of about −10¹³ (refused, before, as a model without a steady filter). The
    generalised Schur method's P̄ is a covariance that solves the DARE, and the steady engine's log-likelihood equals
    the exact engine's, which runs the Riccati recursion from there, without numpy warnings."""
    y, z = np.random.default_rng(0).standard_normal(5000) * 1e-3, np.ones((5000, 1))
    model = ss.from_components([WN(7.62916e-06), GM(tau=7.8895e+06, sigma=305.336),
                                OSC(frequency=0.161392, bandwidth=0.114937, sigma=6.63899e-05), RW(4.40886e-10)],
                               0.01, ramp="measurement", intercept=True, exog_names=())
    phi, q, h, r = model.phi, model.q, model.h, float(model.r)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        P = steady_prediction_covariance(phi, q, h, r)
        steady_ll = kalman.loglik(model, y, z, engine="steady").loglik
        exact_ll = kalman.loglik(model, y, z, engine="exact").loglik
    w = np.linalg.eigvalsh(P)
    assert w[0] >= -1e-8 * w[-1]
    gain = phi @ P @ h
    residual = phi @ P @ phi.T + q - np.outer(gain, gain) / (float(h @ P @ h) + r) - P
    assert np.max(np.abs(residual)) <= 1e-8 * np.max(np.abs(P))
    assert steady_ll == pytest.approx(exact_ll, rel=1e-9)


def test_the_smoother_sums_of_a_nearly_exactly_observed_state_are_finite_without_numpy_warnings():
    """A random walk of 20 beside a white noise of 1e-10 per sample: P̄ singular to rounding. The covariance sums'
    binary doubling squared J once more after its last bit, and that unused power overflowed (RuntimeWarnings in
    the measured-table logs); the sums themselves are finite."""
    y, z = np.random.default_rng(0).standard_normal(5000) * 1e-3, np.ones((5000, 1))
    model = ss.from_components([WN(1.09806e-08), OSC(frequency=14.8243, bandwidth=0.0140424, sigma=704.795),
                                OSC(frequency=0.196866, bandwidth=0.0583459, sigma=0.383911),
                                OSC(frequency=0.261654, bandwidth=0.333958, sigma=1.17607e-06), RW(20.5649)],
                               0.01, ramp="measurement", intercept=True, exog_names=())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        stats = kalman.smooth(model, y, z)
    assert np.all(np.isfinite(stats.sum_p)) and np.isfinite(stats.loglik)


@pytest.mark.parametrize("ramp", ["measurement", "state"])
def test_new_values_give_the_model_assembled_afresh_and_the_ramp_stays_the_profiled_one(ramp):
    # with_components remembers the blocks of the components it has seen (the gradient's steps change one at a
    # time) and to_model takes only the RR blocks back from the profiled model: neither may change what is built
    first = [WN(0.3), GM(tau=20.0, sigma=0.5), OSC(0.2, 0.02, 0.4), BI(0.05, 1.0, 100.0), RW(0.01), RR(1e-3)]
    moved = [WN(0.31), GM(tau=21.0, sigma=0.5), OSC(0.2, 0.02, 0.4), BI(0.05, 1.0, 100.0), RW(0.012), RR(1e-3)]
    base = ss.from_components(first, 0.5, ramp=ramp)
    for comps in (first, moved, first):
        fresh = ss.from_components(comps, 0.5, ramp=ramp)
        again = ss.with_components(base, comps)
        for name in ("phi", "q", "r", "u", "b"):
            assert np.array_equal(getattr(again, name), getattr(fresh, name)), name
    profiled = ss.with_components(base, [*first[:-1], RR(4e-3)])
    par = mle.Parameterisation.of(moved)
    theta = par.to_theta(moved)
    assert par.to_components(theta, profiled)[-1].slope == pytest.approx(4e-3, rel=1e-12)
    for got, want in zip(par.to_components(theta, profiled)[:-1], moved[:-1], strict=True):
        assert got.params() == pytest.approx(want.params(), rel=1e-12)
    assert ss.ramp_components(profiled) == {5: ss.to_components(profiled)[5]}


@pytest.mark.parametrize("m", [1, 2, 4, 5, 7])
def test_the_gram_matrix_of_innovation_columns_is_the_product(m):
    rows = np.random.default_rng(m).standard_normal((m, 10_001))
    got = common.gram(rows)
    np.testing.assert_allclose(got, rows @ rows.T, rtol=1e-12, atol=1e-9)
    np.testing.assert_array_equal(got, got.T)


@pytest.mark.parametrize("a", [[[0.99993]], [[0.999, 50.0], [0.0, 0.9]], [[0.9995, 0.01], [-0.01, 0.9995]]])
def test_the_stein_sum_judged_from_its_spectral_radius_is_the_sum(a):
    """A slow pole, a non-normal pair (a transient of 50× before the decay) and a slow rotation: the sum whose
    increments are judged only from the doubling the spectral radius allows equals the one judged at every doubling,
    and solves M = Aᵀ M A + W."""
    A = np.array(a)
    W = np.eye(A.shape[0]) + 0.3 * np.ones_like(A)
    rho = float(np.max(np.abs(np.linalg.eigvals(A))))
    got = riccati._stein_sum(A, W, rho=rho)
    want = riccati._stein_sum(A, W)
    np.testing.assert_allclose(got, want, rtol=1e-14)
    np.testing.assert_allclose(A.T @ got @ A + W, got, rtol=1e-11)


@pytest.mark.parametrize("n", [1, 2, 7, 64, 1001])
def test_the_affine_power_sums_are_the_sums_of_the_recursion(n):
    """Σ_{k<n} T^k(P0) and T^{n−1}(P0) for T(P) = J P Jᵀ + C, from the doubling, equal the recursion run n times (a
    non-normal J with a slow pole, as a smoother gain beside a walk)."""
    from imu_noise_id.core.kalman.steady import affine_power_sum

    J = np.array([[0.999, 0.3], [0.0, 0.6]])
    C = np.array([[0.5, 0.1], [0.1, 0.2]])
    P0 = np.array([[2.0, -0.4], [-0.4, 1.0]])
    p, total = P0, np.zeros_like(P0)
    for k in range(n):
        total += p
        if k < n - 1:
            p = J @ p @ J.T + C
    got_total, got_last = affine_power_sum(J, C, P0, n)
    np.testing.assert_allclose(got_total, total, rtol=1e-11)
    np.testing.assert_allclose(got_last, p, rtol=1e-11)


@pytest.mark.parametrize("first", [0.0, None])
def test_a_data_column_of_zeros_is_not_filtered_and_its_pass_is_the_recursions(first):
    """The adjustment's passes run the model on a data column of zeros: the steady engine leaves it unfiltered (its
    output is zero) and the pass equals the exact recursion's; a data column that only starts at zero is filtered."""
    from imu_noise_id.core.kalman import steady

    model, y, z = _data(MIXES["WN+GM+RW+RR"], 4000)
    data = np.zeros_like(y) if first is not None else y.copy()
    data[0] = 0.0
    filtered: list[np.ndarray] = []
    spied = steady._filtered_output

    def spy(*args, **kwargs):
        filtered.append(np.asarray(args[3]).copy())
        return spied(*args, **kwargs)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(steady, "_filtered_output", spy)
        got = kalman.loglik(model, data, z)
    assert all(np.any(rows, axis=1).all() for rows in filtered)
    assert sum(rows.shape[0] for rows in filtered) == (2 if first is not None else 3)  # the bias and ramp columns
    want = kalman.loglik(model, data, z, engine="exact")
    assert got.loglik == pytest.approx(want.loglik, rel=1e-9)
    np.testing.assert_allclose(got.beta, want.beta, rtol=1e-7, atol=1e-12)
    np.testing.assert_allclose(got.beta_cov, want.beta_cov, rtol=1e-7)


@pytest.mark.filterwarnings("error::RuntimeWarning")
@pytest.mark.parametrize("columns", [1, 3, 6])
def test_innovations_too_large_to_square_are_refused_without_a_warning(columns):
    """A maximisation's trial point far out (an analyze on 1000 s of a measured gyro met one in an L-BFGS line search)
    can drive the innovations past √(float max): their Gram matrix overflows. The point is refused (InputError, which
    the maximisations read as a point they cannot evaluate, as for the smoother's overflowing covariance sums; it was
    the regressors' "collinear" message, or a log-likelihood of −∞ without regressors), and numpy's overflow warning,
    which had reached the console, is not raised. The same innovations at an ordinary scale give a finite one (each
    column count: one product per pair, or the matrix product)."""
    rng = np.random.default_rng(3)
    e = rng.standard_normal((columns, 1000))
    names = ["y", *(f"b:{i}" for i in range(columns - 1))]
    for constant_f in (True, False):
        fine = common.profile(common.InnovationResult(e, np.ones(1000), np.ones(1000, bool), constant_f), names)
        assert np.isfinite(fine.loglik)
        with pytest.raises(InputError, match="sums of squares overflow"):
            common.profile(common.InnovationResult(e * 1e160, np.ones(1000), np.ones(1000, bool), constant_f), names)


@pytest.mark.filterwarnings("error::RuntimeWarning")
@pytest.mark.parametrize(("phi", "q"), [(np.array([[1e200]]), np.array([[1e300]])),
                                        (np.array([[1.0, 1.0], [0.0, 1.0]]), np.diag([0.0, 1e-300]))])
def test_the_schur_riccati_fallback_refuses_a_degenerate_model_without_a_warning(phi, q):
    """The Riccati equation's Schur fallback (scipy's ``solve_discrete_are``) at a profile's or a maximisation's trial
    point far out: scipy's balancing met values it cannot cast and numpy's warning reached the console (seen in the
    interval-budget and digital-filter tests). Such a point is refused (InputError, which every caller reads as outside
    the filter's domain) or solved to a finite covariance, quietly."""
    try:
        p = riccati._schur_dare(phi, q, np.ones(phi.shape[0]), 1.0)
    except InputError:
        return
    assert np.all(np.isfinite(p))
