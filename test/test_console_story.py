"""The console's loop line says why the loop's start is named otherwise than the fitted model, and the record-length
advice of analyze speaks of the final model."""

from __future__ import annotations

import numpy as np

from imu_noise_id.core.estimation.em.model import fit_model
from imu_noise_id.core.noise.components import GM, RW, WN, simulate_sum
from imu_noise_id.pipelines.loop import run_closed_loop
from imu_noise_id.report.console import loop_line, record_length_lines

DT = 0.01


def test_a_fitted_gm_below_the_filter_memory_is_named_as_the_low_pass_with_the_reason():
    y = simulate_sum([WN(1e-3), GM(tau=0.02, sigma=2e-2), RW(2e-5)], 20_000, DT, np.random.default_rng(4))
    fit = fit_model(y, DT, "WN+GM+RW")
    loop = run_closed_loop(y, DT, fit, max_steps=0)
    assert loop.steps[0].model == "WN+LPF+RW"
    line = loop_line("gyro_z", loop, fit.model).splitlines()[0]
    assert line.startswith("gyro_z: loop WN+LPF+RW (the fitted WN+GM+RW with its shortest GM read as the sensor's "
                           "low-pass")
    assert "(" not in loop_line("gyro_z", loop, "WN+LPF+RW").splitlines()[0]
    assert record_length_lines({"gyro_z": fit})[1].split()[1] == "WN+GM+RW"


def test_the_loop_demo_prints_its_final_models_against_what_was_simulated():
    from types import SimpleNamespace

    from imu_noise_id.demo.loop import truth_table

    def final(model: str) -> SimpleNamespace:
        return SimpleNamespace(final=SimpleNamespace(model=model))

    rows = truth_table({"gyro_x": final("WN+RW"), "gyro_z": final("WN+GM"), "accel_z": final("WN+LPF+RR")})
    rows = [line.split() for line in rows.splitlines()[1:]]
    assert rows[0] == ["gyro_x", "WN+RW", "WN+RW", "-", "as", "simulated"]
    assert rows[1] == ["gyro_z", "WN+GM+RW", "WN+GM", "yes", "−RW"]
    assert rows[2] == ["accel_z", "LPF+RW", "WN+LPF+RR", "yes", "+WN", "+RR", "−RW"]
    # a walk the final model lacks is shown with the K pasted in its place, against the simulated one
    from imu_noise_id.pipelines.analyze.numbers import Reading

    walks = {"gyro_z": Reading(9.7e-4, (0.0, 9.7e-4), "bound"), "accel_z": Reading(1e-5, (0.0, 1e-5), "bound")}
    rows = truth_table({"gyro_z": final("WN+GM"), "accel_z": final("WN+LPF")}, walks).splitlines()[1:]
    assert rows[0].endswith("−RW (K pasted as bound 0.00097 ≥ the simulated 2e-05)")
    assert rows[1].endswith("+WN −RW (K pasted as bound 1e-05 < the simulated 4e-05)")


def test_the_record_length_advice_leaves_out_a_parameter_whose_interval_reaches_zero_and_names_it():
    """200 s of white noise fitted as WN+RW: K's interval reaches zero. A relative precision of a value the data cannot
    tell from zero needs no finite record (the advice had said 7.85e5 h for ±10 %, 'hardest: RW.random_walk, now
    ±37582 %'); the advice is for the parameters resolved from zero, and names the others."""
    y = simulate_sum([WN(1e-3)], 20_000, DT, np.random.default_rng(5))
    fit = fit_model(y, DT, "WN+RW")
    assert fit.ci95["RW.random_walk"][0] == 0.0 < fit.ci95["WN.noise_density"][0]
    line = record_length_lines({"gyro_x": fit})[1]
    assert "enough for +-10 % on every parameter resolved from zero (hardest: WN.noise_density" in line
    assert line.endswith("not resolved from zero, left out: RW.random_walk")


def test_a_signed_ramp_away_from_zero_is_resolved_from_zero():
    """A ramp's slope has a signed interval: one wholly below zero is resolved from it, K's [0, …] is not."""
    y = simulate_sum([WN(1e-3), RW(1e-5)], 40_000, DT, np.random.default_rng(5)) - 2e-6 * np.arange(40_000) * DT
    fit = fit_model(y, DT, "WN+RW+RR")
    assert fit.ci95["RR.slope"][1] < 0.0
    assert fit.not_resolved_from_zero == ["RW.random_walk"]


def test_a_parameter_whose_interval_has_no_upper_end_is_named_not_taken_as_the_hardest():
    """An interval [lo, ∞) (the white noise beside a low-pass on 5 s of a measured accelerometer) has no finite
    precision to reach: the advice had printed "record n/a ... (hardest: WN.noise_density, now +-inf %)" (and the
    report "inf h ... now ±inf %"). It is for the parameters the record bounds, and names the others."""
    import math

    from imu_noise_id.core.estimation.em.results import FitResult, RecordLengthAdvice
    from imu_noise_id.core.noise.components import LPF

    advice = RecordLengthAdvice(0.1, "95 % two-sided, relative half-width", 5.0,
                                {"WN.noise_density": math.inf, "LPF.cutoff": 30.0, "LPF.noise_density": 12.0},
                                {"WN.noise_density": math.inf, "LPF.cutoff": 0.24, "LPF.noise_density": 0.155},
                                {"WN.noise_density": True, "LPF.cutoff": True, "LPF.noise_density": True})
    fit = FitResult(model="WN+LPF", components=[WN(4e-3), LPF(noise_density=5e-3, cutoff=15.0)], exog_coef={},
                    se={}, ci95={"WN.noise_density": (3e-3, math.inf), "LPF.cutoff": (10.0, 20.0),
                                 "LPF.noise_density": (4e-3, 6e-3)},
                    loglik=0.0, aic=0.0, bic=0.0, n=500, dt=DT, n_iter=0, converged=True, record_length=advice)
    from types import SimpleNamespace

    from imu_noise_id.report.analysis_html import _selection_section

    line = record_length_lines({"accel_x": fit})[1]
    html = _selection_section(SimpleNamespace(models={"accel_x": SimpleNamespace(selection=None, fit=fit)},
                                              finals={}))
    assert "WN.noise_density: no upper end" in html and "inf" not in html.replace("info", "")
    assert "record 0.5 min for +-10 % on every parameter the record bounds (hardest: LPF.cutoff, now +-24 %)" in line
    assert line.endswith("no upper end, left out: WN.noise_density") and "n/a" not in line


def test_a_parameter_on_the_edge_of_its_searched_range_says_so():
    """``fit --model WN+GM+RW`` on 20 min of a measured gyro printed "GM.tau 0.01 [0, 0.01004] (profile)": a GM of
    one sample's memory, the least τ searched (the sensor's low-pass, which analyze names LPF), with nothing saying
    the value is the range's end rather than a maximum inside it."""
    import math

    from imu_noise_id.core.estimation.em.results import FitResult
    from imu_noise_id.report.console import parameter_lines

    fit = FitResult(model="WN+GM+RW", components=[WN(4.5e-4), GM(tau=DT, sigma=4e-3), RW(2.3e-5)], exog_coef={},
                    se={}, ci95={"GM.tau": (0.0, 0.01004), "GM.sigma": (3.9e-3, 4.1e-3)}, loglik=0.0, aic=0.0,
                    bic=0.0, n=120_000, dt=DT, n_iter=0, converged=True)
    lines = {line.split()[1]: line for line in parameter_lines("gyro_x", fit)}
    assert "at the lower end of the range searched (0.01 s: one sample)" in lines["GM.tau"]
    assert "range searched" not in lines["GM.sigma"] and "range searched" not in lines["WN.noise_density"]
    assert math.isclose(fit.components[1].tau, DT)


def test_a_parameter_the_record_does_not_resolve_from_zero_is_said_to_be_bounded():
    """``fit --model WN+GM+RW`` on 20 min of WN+GM+RW printed "RW.random_walk 1.839e-10 [0, 3.072e-05] (profile)":
    a number a user pastes, 10⁵ below the walk the record allows. The line now says the record only bounds it."""
    from imu_noise_id.core.estimation.em.results import FitResult
    from imu_noise_id.core.noise.components import RR
    from imu_noise_id.report.console import parameter_lines

    fit = FitResult(model="WN+GM+RW+RR", components=[WN(1e-3), GM(tau=49.0, sigma=3e-4), RW(1.8e-10), RR(-2e-7)],
                    exog_coef={}, se={}, ci95={"WN.noise_density": (9.97e-4, 1.002e-3), "GM.tau": (21.1, 395.4),
                                               "GM.sigma": (2e-4, 6.6e-4), "RW.random_walk": (0.0, 3.072e-5),
                                               "RR.slope": (-5e-7, 1e-7)},
                    loglik=0.0, aic=0.0, bic=0.0, n=240_000, dt=DT, n_iter=0, converged=True)
    lines = {line.split()[1]: line for line in parameter_lines("gyro_x", fit)}
    assert lines["RW.random_walk"].endswith("; not resolved from zero: the record only bounds it, <= 3.072e-05")
    assert lines["RR.slope"].endswith("; its interval holds zero: the record does not tell it from none")
    assert "zero" not in lines["GM.tau"] and "zero" not in lines["WN.noise_density"]
