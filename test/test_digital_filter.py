"""The sensor's digital low-pass (DLPF): its state-space block, autocovariance, Allan variance and spectrum against
independent computations, and N read as the passband level when the model selection fits it."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml
from scipy import linalg, signal

from imu_noise_id.cli import main
from imu_noise_id.core import kalman
from imu_noise_id.core.allan import allan_variance
from imu_noise_id.core.allan.slopes import fit_axis_slopes, rises_early
from imu_noise_id.core.axes import ImuSeries
from imu_noise_id.core.errors import InputError
from imu_noise_id.core.estimation.em import whittle
from imu_noise_id.core.estimation.em.model import FitOptions, NoiseModel
from imu_noise_id.core.estimation.em.selection import select_model, suggest_candidates
from imu_noise_id.core.estimation.readouts import kalibr
from imu_noise_id.core.kalman.statespace import from_components
from imu_noise_id.core.noise.components import RW, WN, simulate_sum
from imu_noise_id.core.noise.digital import DLPF, SensorFilter
from imu_noise_id.core.noise.modelspec import parse_model
from imu_noise_id.pipelines.analyze.models import ModelStage, fit_axis

DT = 0.005


@pytest.mark.parametrize("order", [1, 2, 3, 4])
def test_the_block_is_the_filter(order):
    """The block's stationary output autocovariance h Φ^j P hᵀ (P from the discrete Lyapunov equation) equals R(j)
    from the impulse response of scipy's Butterworth design, and the block converts back to the component."""
    c = DLPF(2e-3, 15.0, order)
    block = c.block(DT)
    p = linalg.solve_discrete_lyapunov(block.phi, block.q)
    lags = np.arange(12)
    from_block = [block.h @ np.linalg.matrix_power(block.phi, j) @ p @ block.h for j in lags]
    b, a = signal.butter(order, 15.0, fs=1.0 / DT)
    h = signal.lfilter(b, a, np.r_[1.0, np.zeros(4000)])
    direct = [c.sigma2(DT) * float(h[: h.size - j] @ h[j:]) for j in lags]
    assert np.allclose(from_block, direct, rtol=1e-8)
    assert np.allclose(c.autocovariance(lags, DT), direct, rtol=1e-8)
    back = DLPF.from_block(block.phi, block.q, DT)
    assert back.order == order
    assert back.noise_density == pytest.approx(2e-3, rel=1e-9) and back.cutoff == pytest.approx(15.0, rel=1e-9)


@pytest.mark.parametrize("order", [1, 2, 3, 4])
@pytest.mark.parametrize("cutoff", [0.025, 0.5, 15.0, 32.8, 45.0])
def test_the_design_is_scipys_butterworth(order, cutoff):
    """DLPF.coefficients (built from the poles) is scipy.signal.butter's design at the sampling rate."""
    b, a = DLPF(2e-3, cutoff, order).coefficients(DT)
    b_scipy, a_scipy = signal.butter(order, cutoff, fs=1.0 / DT)
    np.testing.assert_allclose(b, b_scipy, rtol=1e-12, atol=1e-14 * np.max(np.abs(b_scipy)))
    np.testing.assert_allclose(a, a_scipy, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("order", [1, 2, 3, 4])
@pytest.mark.parametrize("cutoff", [0.05, 15.0, 90.0])
def test_the_sample_spectrum_is_the_bilinear_butterworths(order, cutoff):
    """DLPF.sample_spectrum (the poles' factored form the Whittle likelihood reads) against the bilinear Butterworth's
    magnitude in closed form, σ²/(1 + (tan(ω/2)/tan(ω_c/2))²ⁿ), from a cutoff 2·10⁻⁴ of the rate to 0.45 of it; at
    15 Hz also against the block's spectrum h (zI − Φ)⁻¹ Q (…)ᴴ hᵀ solved per frequency and scipy's freqz of
    scipy's design (DLPF.psd is this spectrum times dt), where the spectrum is above 1e-12 of its largest value
    (both lose relative precision towards Nyquist, and at low cutoffs the design's coefficients cancel: 1e-4 off at
    0.05 Hz, order 4)."""
    c = DLPF(2e-3, cutoff, order)
    omega = np.linspace(1e-5, math.pi - 1e-3, 3000)
    direct = c.sample_spectrum(omega, DT)
    ratio = np.tan(0.5 * omega) / math.tan(math.pi * cutoff * DT)
    np.testing.assert_allclose(direct, c.sigma2(DT) / (1.0 + ratio ** (2 * order)), rtol=1e-10)
    if cutoff == 15.0:
        block = c.block(DT)
        by_block = whittle.block_spectrum(block.phi, block.q, block.h, omega)
        b, a = signal.butter(order, cutoff, fs=1.0 / DT)
        by_design = c.sigma2(DT) * np.abs(signal.freqz(b, a, worN=omega)[1]) ** 2
        shown = direct > 1e-12 * direct.max()
        np.testing.assert_allclose(direct[shown], by_block[shown], rtol=1e-8)
        np.testing.assert_allclose(direct[shown], by_design[shown], rtol=1e-8)


def test_the_steady_engine_runs_a_low_cutoff_filter_as_the_exact_engine_does():
    """A fourth-order DLPF at 0.59 Hz beside a walk at 200 Hz (a fit the selection reached on a record with a 0.5 Hz
    line): the steady-state Riccati solution is a fixed point to rounding, and the steady engine's likelihood and
    smoother sums equal the time-varying (exact) engine's, which starts at the same P̄; the smoother's sums stay finite
    over a 20-minute record."""
    comps = [WN(4.99e-4), DLPF(1.79e-3, 0.586, 4), RW(3.33e-5)]
    model = from_components(comps, DT, intercept=False)
    P = model.steady_prediction_covariance()
    Ph = P @ model.h
    step = model.phi @ (P - np.outer(Ph, Ph) / (model.h @ Ph + model.r)) @ model.phi.T + model.q
    assert np.max(np.abs(step - P)) <= 1e-9 * np.max(np.abs(P))
    y = simulate_sum(comps, 240_000, DT, np.random.default_rng(3))
    exact = kalman.smooth(model, y[:20_000], engine="exact")
    steady = kalman.smooth(model, y[:20_000], engine="steady")
    assert steady.loglik == pytest.approx(exact.loglik, abs=1e-4)
    for name in ("sum_p", "p_first", "sum_lag"):
        assert np.allclose(getattr(steady, name), getattr(exact, name), rtol=1e-6, atol=1e-9 * np.max(
            np.abs(getattr(exact, name)))), name
    whole = kalman.smooth(model, y, engine="steady")
    assert np.all(np.isfinite(whole.sum_p)) and np.all(np.diag(whole.sum_p) > 0)


def test_allan_variance_and_sums_against_brute_force():
    """AV(m·dt) and Var(y_1 + … + y_m) from the prefix sums against the double sum of R over i, j < m."""
    c = DLPF(1e-3, 7.0, 2)
    r = c.autocovariance(np.arange(400), DT)
    for m in (1, 2, 5, 17, 60, 150):
        brute = sum(r[abs(i - j)] for i in range(m) for j in range(m))
        assert c.block_sum_variance(np.array([m]), DT)[0] == pytest.approx(brute, rel=1e-9)
        brute_2m = sum(r[abs(i - j)] for i in range(2 * m) for j in range(2 * m))
        av = (4 * brute - brute_2m) / (2 * m * m)
        assert c.allan_variance(np.array([m * DT]), DT)[0] == pytest.approx(av, rel=1e-8)
    # beyond its memory the AV falls as N²/τ (less a term in memory/τ): N is the passband density
    tau = np.array([20.0])
    assert c.allan_variance(tau, DT)[0] * tau[0] == pytest.approx(1e-6, rel=3e-3)
    assert c.zero_frequency_density(DT) == 1e-3


def test_simulation_spectrum_and_spec():
    c = parse_model("DLPF(1e-3, 12, order=2)")[0]
    assert c == DLPF(1e-3, 12.0, 2)
    y = c.simulate(400_000, DT, np.random.default_rng(1))
    f, welch = signal.welch(y, fs=1.0 / DT, nperseg=2048)
    band = (f > 1.0) & (f < 60.0)
    assert np.allclose(welch[band] / (2.0 * c.psd(f[band], DT)), 1.0, atol=0.15)
    assert c.psd(np.array([99.99]), DT)[0] < 1e-6 * c.psd(np.array([0.1]), DT)[0]  # the bilinear zero at Nyquist
    with pytest.raises(ValueError, match="Nyquist"):
        DLPF(1e-3, 120.0).block(DT)
    with pytest.raises(ValueError, match="order"):
        DLPF(1e-3, 12.0, 5)


def test_the_selection_fits_a_second_order_dlpf_and_pastes_its_passband_level():
    """5 min at 200 Hz: white noise (1e-3) through a 2nd-order Butterworth at 12 Hz, a white floor of a tenth of it
    after the filter (the ADC's) and a random walk. The AV shows the roll-off, the selection offers WN+DLPF+RW and
    takes it, and N (√(N_WN² + N_DLPF²)) is within 3 % of the passband level, inside its interval; the first-order
    fits had put the filtered noise in a GM beside a white noise driven to ~0 (N 10⁶ below)."""
    rng = np.random.default_rng(12)
    n = 60_000
    w = rng.standard_normal(n + 4000) * 1e-3 / math.sqrt(DT)
    y = signal.sosfilt(signal.butter(2, 12.0, fs=1.0 / DT, output="sos"), w)[4000:]
    y = y + simulate_sum([WN(1e-4), RW(2e-5)], n, DT, rng)
    data = np.column_stack([y] * 6)
    imu = ImuSeries(np.arange(n) * DT, data[:, :3], data[:, 3:])
    model = fit_axis(imu, "gyro_x", ModelStage(), DT, allan_variance(y, DT))
    assert "WN+DLPF+RW" in [row["model"] for row in model.selection.table]
    assert model.fit.model.startswith("WN+DLPF")
    n_hat = kalibr.noise_density(model.fit)
    passband = math.hypot(1e-3, 1e-4)
    assert n_hat.value == pytest.approx(passband, rel=0.03)
    assert n_hat.ci95[0] <= passband <= n_hat.ci95[1]


@pytest.mark.parametrize(("rate", "cutoff", "order", "seed"), [(200.0, 5.0, 2, 120_772), (400.0, 20.0, 1, 113_068)])
def test_k_behind_a_filter_spans_the_reading_of_a_gm_beside_the_walk(rate, cutoff, order, seed):
    """5 min through a Butterworth low-pass (bench_dlpf's records of these cells), with a GM (τ 20 s, σ 3e-4) and a
    walk K = 2e-5: the filter rules out every unfiltered candidate (ΔBIC > 2000), and WN+DLPF+RW reads the GM's
    wander as a walk, K ≈ 3× the truth with an interval above it. The selection now also fits WN+DLPF+GM+RW, started
    from WN+DLPF+RW's fit with its walk split into a slow GM (its AV-fit starts, at 400 Hz, climbed to a GM of 7 ms
    1.9 log-likelihood units lower); it finds the GM with K ≈ 0 within ΔAIC 2 ln 20 of the winner, and K's interval,
    spanning its reading, holds the truth."""
    from imu_noise_id.core.estimation.readouts.walk_evidence import over_structures, plausible_walks
    from imu_noise_id.core.noise.components import GM

    dt = 1.0 / rate
    rng = np.random.default_rng(seed)
    n, warm = int(300 * rate), int(20 * rate / cutoff) + 1000
    w = rng.standard_normal(n + warm) * 1e-3 / math.sqrt(dt)
    y = signal.sosfilt(signal.butter(order, cutoff, fs=rate, output="sos"), w)[warm:]
    y = y + simulate_sum([WN(1e-4), GM(tau=20.0, sigma=3e-4), RW(2e-5)], n, dt, rng)
    selection = select_model(y, dt, allan=allan_variance(y, dt))
    assert selection.best.model == "WN+DLPF+RW"
    own = kalibr.random_walk(selection.best)
    assert own.method == "model" and own.ci95[0] > 2e-5  # the winner alone: above the truth
    beside = selection.fits["WN+DLPF+GM+RW"]
    assert next(c.tau for c in beside.components if isinstance(c, GM)) > 10.0  # the slow mode
    readings = plausible_walks(selection, n, dt)
    assert "WN+DLPF+GM+RW" in [r.structure for r in readings]
    k = over_structures(own, readings)
    assert k.ci95[0] < 2e-5 <= k.ci95[1] and "WN+DLPF+GM+RW" in k.source, (k, own)


@pytest.mark.filterwarnings("error::RuntimeWarning")  # the intervals' trial points overflowed onto the console
@pytest.mark.parametrize(("order", "rate", "cutoff"), [(1, 200.0, 12.0), (3, 200.0, 12.0), (4, 200.0, 12.0),
                                                      (4, 200.0, 20.0), (4, 200.0, 40.0), (4, 400.0, 100.0)])
def test_the_fit_takes_the_filters_order(order, rate, cutoff):
    """5 min through a Butterworth of ``order`` (a white floor and a random walk beside it): the fit of WN+DLPF+RW ends
    at that order (chosen among the starts by the Whittle likelihood; before, every DLPF was of the second order and
    the loop added resonances for the rest of the roll-off), and N is within 4 % of the passband level. At a quarter
    of the rate the AV's start had put the white floor at ~0, and from there the Whittle fits had taken the filter of
    the first order with its cutoff at the Nyquist frequency (N 10⁵ low). At 20 Hz of 200 Hz the third order's start
    (17.8 Hz) had the fourth's Allan variance within 10 % at every τ and was kept in its place, so the exact
    likelihood never saw the fourth order (N 6 % high, and the loop added an OSC for the rest)."""
    dt = 1.0 / rate
    rng = np.random.default_rng(12 + order)
    n = int(300 * rate)
    w = rng.standard_normal(n + 4000) * 1e-3 / math.sqrt(dt)
    y = signal.sosfilt(signal.butter(order, cutoff, fs=rate, output="sos"), w)[4000:]
    y = y + simulate_sum([WN(1e-4), RW(2e-5)], n, dt, rng)
    fit = NoiseModel(y, dt, "WN+DLPF+RW").fit()
    dlpf = next(c for c in fit.components if isinstance(c, DLPF))
    assert dlpf.order == order
    assert dlpf.cutoff == pytest.approx(cutoff, rel=0.05)
    assert kalibr.noise_density(fit).value == pytest.approx(math.hypot(1e-3, 1e-4), rel=0.04)


def test_a_known_sensor_filter_is_offered_and_its_order_kept():
    """The user's sensor filter: without a roll-off in the data the selection still offers (and judges) WN+DLPF+RW;
    with one, the fitted DLPF has the order the user gave (here 2, where the data's filter is of the fourth order:
    the user's configuration is taken, the data choose only without it)."""
    rng = np.random.default_rng(5)
    n = 60_000
    plain = simulate_sum([WN(1e-3), RW(2e-5)], n, DT, rng)
    known = SensorFilter(20.0, 2)
    assert "WN+DLPF+RW" not in suggest_candidates(allan_variance(plain, DT))
    table = select_model(plain, DT, options=FitOptions(uncertainty=False), sensor_filter=known).table
    assert "WN+DLPF+RW" in [row["model"] for row in table]
    w = rng.standard_normal(n + 4000) * 1e-3 / math.sqrt(DT)
    y = signal.sosfilt(signal.butter(4, 12.0, fs=1.0 / DT, output="sos"), w)[4000:] + plain * 0.1
    told = NoiseModel(y, DT, "WN+DLPF+RW", sensor_filter=SensorFilter(12.0, 2))
    fit = told.fit(options=FitOptions(uncertainty=False))
    assert next(c for c in fit.components if isinstance(c, DLPF)).order == 2
    with pytest.raises(InputError, match="Nyquist"):
        NoiseModel(y, DT, "WN+DLPF+RW", sensor_filter=SensorFilter(120.0))


def test_analyze_takes_the_sensor_filter_option(tmp_path, capsys):
    """``analyze --sensor-filter HZ:ORDER`` on a bag whose noise passes a fourth-order filter: model.yaml's DLPF has
    that order; a cutoff above the Nyquist frequency and a malformed value are refused (exit 2) with the option
    named."""
    bag = tmp_path / "dlpf"
    assert main(["simulate", "--model", "WN(1e-4)+DLPF(1e-3, 12, order=4)+RW(2e-5)", "--rate", "200",
                 "--duration", "120", "--out", str(bag), "--seed", "3"]) == 0
    out = tmp_path / "out"
    assert main(["analyze", str(bag), "--out", str(out), "--model", "WN+DLPF+RW", "--no-loop", "--jobs", "1",
                 "--sensor-filter", "12:4"]) == 0
    text = (out / "model.yaml").read_text()
    assert yaml.safe_load(text)["run"]["options"]["sensor_filter"] == "12:4"
    assert "DLPF" in text and "order: 4.0" in text
    capsys.readouterr()
    assert main(["analyze", str(bag), "--out", str(tmp_path / "out2"), "--sensor-filter", "150"]) == 2
    assert "--sensor-filter" in capsys.readouterr().err
    with pytest.raises(SystemExit) as stop:
        main(["analyze", str(bag), "--out", str(tmp_path / "out3"), "--sensor-filter", "12:5"])
    assert stop.value.code == 2
    assert "--sensor-filter" in capsys.readouterr().err


def test_starts_with_filters_of_other_orders_are_kept_though_their_allan_variances_agree():
    from imu_noise_id.core.allan import allan_variance
    from imu_noise_id.core.estimation.em import starts
    from imu_noise_id.core.noise.components import total_allan_variance

    dt = 1.0 / 200.0
    tau = allan_variance(np.random.default_rng(0).standard_normal(20_000), dt).tau
    third = [WN(1e-4), DLPF(noise_density=1.015e-3, cutoff=19.2, order=3), RW(2e-5)]
    fourth = [WN(1e-4), DLPF(noise_density=1.0e-3, cutoff=20.0, order=4), RW(2e-5)]
    fourth_again = [WN(1e-4), DLPF(noise_density=1.005e-3, cutoff=20.2, order=4), RW(2e-5)]
    curves = [np.log(total_allan_variance(c, tau, dt)) for c in (third, fourth, fourth_again)]
    assert np.max(np.abs(curves[0] - curves[1])) < 0.04 and np.max(np.abs(curves[2] - curves[1])) < 0.04
    kept = starts.distinct([(0.0, third), (1.0, fourth), (2.0, fourth_again)], tau, dt)
    assert [c for _, c in kept] == [third, fourth]  # the same order within 10 % at every τ: one start


def test_a_slow_filter_over_a_white_floor_is_offered_the_dlpf():
    """A second-order Butterworth at 5 Hz sampled at 1 kHz, a white floor of a tenth after it: the AV falls on the
    floor's line, rises over the filter's hump and leaves it more slowly than white noise; the rise offers
    WN+DLPF+RW, which the selection then prefers to the GM that took the hump, and the Allan slopes read N past the
    hump (not on the floor's line). White noise with a walk, with flicker or with quantisation offers no DLPF."""
    rate, n = 1000.0, 120_000
    rng = np.random.default_rng(52)
    w = rng.standard_normal(n + 4000) * 1e-3 * math.sqrt(rate)
    floor = simulate_sum([WN(1e-4), RW(2e-5)], n, 1.0 / rate, rng)
    y = signal.sosfilt(signal.butter(2, 5.0, fs=rate, output="sos"), w)[4000:] + floor
    av = allan_variance(y, 1.0 / rate)
    assert rises_early(av)
    assert "WN+DLPF+RW" in suggest_candidates(av)
    reading = fit_axis_slopes(av).noise_density  # read past the hump, not on the floor's line before it
    assert reading.value == pytest.approx(math.hypot(1e-3, 1e-4), rel=0.1)  # the floor's line is 10× lower
    best = select_model(y, 1.0 / rate, options=FitOptions(uncertainty=False)).best
    assert any(isinstance(c, DLPF) for c in best.components)
    assert kalibr.noise_density(best).value == pytest.approx(math.hypot(1e-3, 1e-4), rel=0.03)
    for spec in ("WN(1e-3)+RW(2e-5)", "WN(2e-3)+BI(2e-3, 0.1, 1200)", "WN(1e-3)+QN(1e-5)+RW(2e-5)"):
        plain = simulate_sum(parse_model(spec), n, 1.0 / rate, rng)
        assert not rises_early(allan_variance(plain, 1.0 / rate)), spec
