"""Sinusoidal regressor columns: recognised only when they are sinusoids, and their closed-form steady-state response
equal to the filter's (the plain steady filter and the exact time-varying recursion)."""

from __future__ import annotations

import contextlib
import math

import numpy as np
import pytest
from kalman_checks import assert_state_sums_close

from imu_noise_id.core import kalman
from imu_noise_id.core.estimation.em.model import NoiseModel
from imu_noise_id.core.kalman import basis, harmonic, steady
from imu_noise_id.core.kalman import statespace as ss
from imu_noise_id.core.noise.components import BI, GM, RW, WN, simulate_sum
from imu_noise_id.core.noise.resonant import LPF, OSC

DT = 0.01


def _sin_cos(freqs, n):
    t = DT * np.arange(n)
    return np.column_stack([f(2 * math.pi * fr * t) for fr in freqs for f in (np.sin, np.cos)])


@pytest.mark.parametrize("freq", [0.0101, 0.5, 7.3, 49.5])
def test_a_sinusoid_column_is_recognised_with_its_frequency(freq):
    n = 200_000
    for column in _sin_cos([freq], n).T:
        assert harmonic.sinusoid_omega(column) == pytest.approx(2 * math.pi * freq * DT, rel=1e-9)
    shifted = 3.0 * np.cos(2 * math.pi * freq * DT * np.arange(n) + 1.1)
    assert harmonic.sinusoid_omega(shifted) == pytest.approx(2 * math.pi * freq * DT, rel=1e-9)


def test_columns_that_are_not_sinusoids_are_not_recognised():
    n = 50_000
    t = DT * np.arange(n)
    rng = np.random.default_rng(3)
    others = {
        "step": (np.arange(n) >= n // 3).astype(float), "zeros": np.zeros(n),
        "ramp with a bend": np.where(t < 100.0, t, 100.0 + 1.001 * (t - 100.0)),
        "noise": rng.standard_normal(n), "temperature": 20.0 + 0.1 * np.cumsum(rng.standard_normal(n)) * DT,
        "amplitude modulated": (1.0 + 0.1 * t / t[-1]) * np.sin(2 * math.pi * 2.0 * t),
        "chirp": np.sin(2 * math.pi * (2.0 + 0.01 * t) * t),
        "sinusoid plus noise": np.sin(2 * math.pi * 2.0 * t) + 1e-6 * rng.standard_normal(n),
        "below the lowest frequency": np.sin(1e-7 * np.arange(n) + 0.2),
    }
    for name, column in others.items():
        assert math.isnan(harmonic.sinusoid_omega(column)), name


def test_constants_and_ramps_are_declared_at_omega_zero():
    """y_{t+1} + y_{t−1} = 2y_t (the recurrence at ω = 0) holds exactly for the lines c₀ + c₁t and for nothing else;
    a line is checked at every sample, not only by its local second differences (a slow arc is not a line)."""
    n = 50_000
    t = DT * np.arange(n)
    for column in (np.ones(n), -np.ones(n), t, 20.0 - 0.3 * t, t - t.mean()):
        assert harmonic.sinusoid_omega(column) == 0.0
        assert harmonic.obeys(column, 0.0)
    arc = np.cos(1e-5 * np.arange(n))  # second differences 1e-10, 0.012 off the line through its ends
    assert harmonic.sinusoid_omega(arc) == pytest.approx(1e-5, rel=1e-6) and not harmonic.obeys(arc, 0.0)
    assert not harmonic.obeys(np.zeros(n), 0.0)
    assert harmonic.affine_coefficients(20.0 - 0.3 * t) == pytest.approx((20.0, -0.3 * DT), rel=1e-12)


def test_the_noise_model_declares_its_sinusoid_columns_and_nothing_else():
    n = 20_000
    t = DT * np.arange(n)
    exog = np.column_stack([_sin_cos([1.7], n), 20.0 + 0.01 * t + 1e-5 * t**2])
    y = np.random.default_rng(0).standard_normal(n)
    model = NoiseModel(y, DT, "WN+RW+RR", exog=exog, exog_names=["s", "c", "temp"])
    omega = 2 * math.pi * 1.7 * DT
    declared = model.statespace(model.starting_values(1, False)[0]).sinusoid_omega
    assert [math.isnan(w) for w in declared] == [False, False, False, False, True]  # bias, ramp, s, c, temp
    assert declared[:2] == (0.0, 0.0)
    assert declared[2] == pytest.approx(omega, rel=1e-9) and declared[3] == pytest.approx(omega, rel=1e-9)


@contextlib.contextmanager
def _closed_form_spy(schur: bool, closed_form: str = "_sinusoid_output"):
    """The rows the steady engine computes by its function ``closed_form`` (the sinusoids' or the lines'), listed
    while the block runs (in the Schur basis when ``schur``: every model falls back to it)."""
    closed_rows: list[int] = []
    with pytest.MonkeyPatch.context() as mp:
        if schur:
            mp.setattr(basis, "MODAL_MAX_COND", 0.0)
        spied = getattr(steady, closed_form)

        def spy(*args, rows, **kwargs):
            closed_rows.extend(rows.tolist())
            return spied(*args, rows=rows, **kwargs)

        mp.setattr(steady, closed_form, spy)
        yield closed_rows


CASES = {
    "RW and a short GM": [WN(2e-3), GM(tau=1.0, sigma=1e-3), RW(3e-4)],
    "GM of 1e6 s beside RW (poles near 1)": [WN(2e-3), GM(tau=1e6, sigma=1e-5), RW(3e-4)],
    "narrow OSC at a line": [WN(2e-3), OSC(frequency=0.5, bandwidth=0.002, sigma=1e-2), RW(3e-4)],
    "flicker ladder and a low-pass": [WN(2e-3), LPF(noise_density=2e-3, cutoff=20.0), BI(1e-4, 0.1, 600.0)],
}


@pytest.mark.parametrize("schur", [False, True])
@pytest.mark.parametrize("name", list(CASES))
def test_the_closed_form_response_equals_the_filter(name, schur):
    """Twelve lines (half of them besides the OSC's frequency, one near Nyquist), in both bases of the steady
    engine: the profile, the GLS means, the innovations and the smoother as when every column is filtered, and the
    log-likelihood as the exact recursion's."""
    comps = CASES[name]
    n = 60_000
    freqs = [0.49, 0.5, 0.51, 1.0, 1.37, 2.0, 3.3, 5.0, 7.77, 11.0, 23.0, 49.0]
    exog = _sin_cos(freqs, n)
    y = simulate_sum(comps, n, DT, np.random.default_rng(11)) + 0.2 + exog @ np.linspace(-1e-2, 1e-2, exog.shape[1])
    z = np.asfortranarray(np.column_stack([np.ones(n), exog]))
    omega = tuple(harmonic.sinusoid_omega(c) for c in z.T)
    assert sum(w > 0.0 for w in omega) == 2 * len(freqs) and omega[0] == 0.0
    names = [f"{k}{i}" for i in range(len(freqs)) for k in ("s", "c")]
    declared = ss.from_components(comps, DT, exog_names=names, sinusoid_omega=omega)
    plain = declared.copy(sinusoid_omega=())
    with _closed_form_spy(schur) as closed_rows:
        got, _, got_stats = kalman.profile_and_smooth(declared, y, z)
        assert sorted(set(closed_rows)) == list(range(2, 2 + 2 * len(freqs)))  # every line column, not the bias
        want, _, want_stats = kalman.profile_and_smooth(plain, y, z)
    scale = float(np.max(np.abs(want.innovations)))
    assert got.loglik == pytest.approx(want.loglik, abs=1e-7)
    np.testing.assert_allclose(got.beta, want.beta, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(got.beta_cov, want.beta_cov, rtol=1e-7, atol=1e-14)
    np.testing.assert_allclose(got.innovations, want.innovations, atol=1e-10 * scale)
    assert_state_sums_close(got_stats.states, want_stats.states, y, z, rtol=1e-8, atol_rel=1e-10)
    if not schur and name != "flicker ladder and a low-pass":  # the exact engine is a Python loop: 60k samples
        exact = kalman.loglik(plain, y, z, engine="exact")
        assert got.loglik == pytest.approx(exact.loglik, abs=1e-6)


@pytest.mark.parametrize("schur", [False, True])
def test_one_line_beside_fast_poles_is_in_closed_form_too(schur):
    """One SIN term (two columns, fewer than the states) on a filter whose poles die out in a few hundred samples:
    the free responses cost little, so the closed form is used, and it equals the filter."""
    comps = [WN(2e-3), GM(tau=0.05, sigma=1e-3), LPF(noise_density=1e-3, cutoff=10.0)]
    n = 30_000
    exog = _sin_cos([3.1], n)
    y = simulate_sum(comps, n, DT, np.random.default_rng(4)) + exog @ [2e-3, -1e-3]
    z = np.asfortranarray(np.column_stack([np.ones(n), exog]))
    declared = ss.from_components(comps, DT, exog_names=["s", "c"],
                                  sinusoid_omega=tuple(harmonic.sinusoid_omega(c) for c in z.T))
    with _closed_form_spy(schur) as closed_rows:
        got = kalman.loglik(declared, y, z)
        want = kalman.loglik(ss.from_components(comps, DT, exog_names=["s", "c"]), y, z)
    assert closed_rows == [2, 3]
    assert got.loglik == pytest.approx(want.loglik, abs=1e-8)
    np.testing.assert_allclose(got.beta, want.beta, rtol=1e-9)


def test_a_declared_column_that_is_not_the_sinusoid_run_is_filtered():
    """The model declares a sinusoid; the column it is run on is another (a temperature series): the engine sees
    it, filters the column, and the result is the plain filter's."""
    n = 20_000
    comps = [WN(2e-3), RW(3e-4)]
    y = simulate_sum(comps, n, DT, np.random.default_rng(2))
    t = DT * np.arange(n)
    declared = ss.from_components(comps, DT, exog_names=["temp"], sinusoid_omega=(math.nan, 0.3))
    z = np.column_stack([np.ones(n), 20.0 + np.sin(0.3 * np.arange(n)) * (1.0 + t)])
    got = kalman.loglik(declared, y, z)
    want = kalman.loglik(ss.from_components(comps, DT, exog_names=["temp"]), y, z)
    assert got.loglik == want.loglik
    np.testing.assert_array_equal(got.beta, want.beta)


def test_a_filter_pole_at_the_line_leaves_the_column_to_the_filter():
    a = np.array([[math.cos(0.3), math.sin(0.3)], [-math.sin(0.3), math.cos(0.3)]]) * (1.0 - 1e-9)
    poles = np.linalg.eigvals(a)
    assert not harmonic.usable(poles, 0.3)
    assert harmonic.usable(poles, 0.31)
    assert harmonic.usable(np.zeros(0), 0.3)
    assert harmonic.free_response_length(poles, 10**12) == pytest.approx(math.log(1e-22) / -1e-9, rel=1e-6)
    assert harmonic.free_response_length(poles, 10**6) == 10**6
    assert harmonic.free_response_length(np.array([0.5]), 10**6) == 75


def test_a_sinusoid_declared_for_a_different_number_of_regressors_is_refused():
    from imu_noise_id.core.errors import InputError

    with pytest.raises(InputError, match="sinusoid_omega"):
        ss.from_components([WN(1e-3), RW(1e-4)], DT, exog_names=["s"], sinusoid_omega=(0.1,))


AFFINE_CASES = {
    "a walk at its zero boundary (a pole 1e-4 from 1)": [WN(1e-3), GM(tau=5.0, sigma=1e-3), RW(1e-7)],
    "narrow OSC and a fast GM (complex and real modes)": [WN(2e-3), OSC(frequency=0.5, bandwidth=0.002, sigma=1e-2),
                                                          GM(tau=0.05, sigma=1e-3)],
    "flicker ladder and a low-pass": [WN(2e-3), LPF(noise_density=2e-3, cutoff=20.0), BI(1e-4, 0.1, 600.0)],
}


@pytest.mark.parametrize("schur", [False, True])
@pytest.mark.parametrize("name", list(AFFINE_CASES))
def test_the_bias_and_the_ramp_in_closed_form_equal_the_filter(name, schur):
    """The bias and ramp columns (declared at ω = 0) from the step response and its running sum: the GLS means,
    their covariance, the innovations and the smoothed states as when both columns are filtered."""
    comps = AFFINE_CASES[name]
    n = 60_000
    t = DT * np.arange(n)
    y = simulate_sum(comps, n, DT, np.random.default_rng(5)) + 0.2 + 3e-5 * t
    z = np.asfortranarray(np.column_stack([np.ones(n), t]))
    omega = tuple(harmonic.sinusoid_omega(c) for c in z.T)
    assert omega == (0.0, 0.0)
    declared = ss.from_components(comps, DT, exog_names=["ramp"], sinusoid_omega=omega)
    plain = declared.copy(sinusoid_omega=())
    with _closed_form_spy(schur, "_affine_output") as affine_rows:
        got, _, got_stats = kalman.profile_and_smooth(declared, y, z)
        assert affine_rows == [1, 2]
        want, _, want_stats = kalman.profile_and_smooth(plain, y, z)
    assert got.loglik == pytest.approx(want.loglik, abs=1e-7)
    np.testing.assert_allclose(got.beta, want.beta, rtol=1e-8)
    np.testing.assert_allclose(got.beta_cov, want.beta_cov, rtol=1e-7)
    np.testing.assert_allclose(got.innovations, want.innovations, atol=1e-10 * float(np.max(np.abs(want.innovations))))
    assert_state_sums_close(got_stats.states, want_stats.states, y, z, rtol=1e-8, atol_rel=1e-10)


def test_the_step_response_in_closed_form_is_the_recursion():
    """s_t of x_{t+1} = A x_t + ΦK from x_0 = 0 in the modal basis, against the recursion run sample by sample."""
    model = ss.from_components([WN(2e-3), OSC(frequency=3.0, bandwidth=0.5, sigma=1e-2), GM(tau=2.0, sigma=1e-3),
                                RW(1e-5)], DT)
    g = steady.gains(model)
    b = steady.decoupled_basis(g.a)
    assert b.modal
    n = 5000
    got = steady._step_response(model, g, b, n)
    x, want = np.zeros(model.n_states), np.empty(n)
    drive = model.phi @ g.k
    for i in range(n):
        want[i] = model.h @ x
        x = g.a @ x + drive
    np.testing.assert_allclose(got, want, rtol=1e-11, atol=1e-13 * float(np.max(np.abs(want))))
