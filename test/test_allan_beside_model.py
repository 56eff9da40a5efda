"""The Allan-slope readings printed and written beside the final models' numbers: where the two 95 % intervals share
no value the outputs say so, name both and say which is pasted, instead of showing two contradicting K's unlabelled."""

from __future__ import annotations

import math

import pytest
import yaml

from imu_noise_id.core.axes import AXES, GYRO_AXES
from imu_noise_id.core.noise.components import GM, RW, WN
from imu_noise_id.core.simulation.static import simulate_static_imu
from imu_noise_id.pipelines.analyze import AnalyzeOptions, ModelStage, analyze
from imu_noise_id.pipelines.analyze.numbers import AxisNumbers, Reading
from imu_noise_id.report.analysis import write_analysis
from imu_noise_id.report.console import summary_table

K_TRUE = 1e-5  # rad/s²/√Hz


def _axis(pasted_k: Reading, allan_k: Reading) -> AxisNumbers:
    n = Reading(1e-3, (0.99e-3, 1.01e-3), "model")
    return AxisNumbers("gyro_x", n, pasted_k, Reading(1e-3, (0.98e-3, 1.02e-3), "fit"), allan_k)


@pytest.mark.parametrize(("pasted", "allan", "flagged"), [
    (Reading(1e-5, (0.7e-5, 1.4e-5), "model"), Reading(5e-5, (4e-5, 6e-5), "fit"), ("random_walk",)),
    (Reading(1e-5, (0.7e-5, 4.5e-5), "model"), Reading(5e-5, (4e-5, 6e-5), "fit"), ()),  # they overlap
    (Reading(2e-5, (0.0, 2e-5), "bound"), Reading(5e-5, (4e-5, 6e-5), "fit"), ("random_walk",)),
    (Reading(5e-5, (3e-5, 7e-5), "model"), Reading(2e-5, (0.0, 2e-5), "upper_bound"), ("random_walk",)),
    (Reading(5e-5, (4e-5, 6e-5), "allan_slope"), Reading(5e-5, (4e-5, 6e-5), "fit"), ()),  # the slope's own
    (Reading(1e-5, (0.7e-5, math.inf), "model"), Reading(5e-5, (4e-5, 6e-5), "fit"), ()),  # no finite end
])
def test_a_reading_disagrees_with_the_pasted_number_only_where_their_intervals_share_no_value(pasted, allan, flagged):
    assert _axis(pasted, allan).allan_disagreements() == flagged


@pytest.fixture(scope="module")
def beside_a_gm(tmp_path_factory):
    """1 h at 100 Hz of gyros WN 3e-4 + GM (τ 30 s, σ 3e-4) + RW 1e-5, fitted with that structure; the imu.yaml and
    report written from it."""
    model = {a: [WN(3e-4), GM(tau=30.0, sigma=3e-4), RW(K_TRUE)] if a in GYRO_AXES else [WN(2e-3), RW(3e-4)]
             for a in AXES}
    imu = simulate_static_imu(model, 100.0, 3600.0, seed=2)
    result = analyze(imu, options=AnalyzeOptions(kinds=("allan",), models=ModelStage("WN+GM+RW"), loop=False, jobs=1,
                                                 axes=GYRO_AXES))
    out = tmp_path_factory.mktemp("beside_a_gm")
    write_analysis(result, out, meta={})
    return result, out


def test_beside_a_gm_the_allan_slopes_walk_is_named_as_disagreeing_with_the_models(beside_a_gm):
    """The +1/2 line read through the GM's bump puts K's interval above the truth; the final model's holds it. Each
    axis says the two do not overlap and which is pasted; N, read alike by both, is not flagged."""
    result, _ = beside_a_gm
    printed = summary_table(result.static, result.numbers)
    assert printed.splitlines()[1].startswith("Allan-slope readings")
    assert "imu.yaml pastes the final models' numbers" in printed.splitlines()[1]
    for axis in GYRO_AXES:
        numbers = result.numbers.axis(axis)
        assert numbers.allan_random_walk.ci95[0] > K_TRUE >= numbers.random_walk.ci95[0]
        assert numbers.random_walk.ci95[1] >= K_TRUE
        assert numbers.allan_disagreements() == ("random_walk",)
        line = next(ln for ln in printed.splitlines() if ln.startswith(axis) and "do not overlap" in ln)
        assert f"{numbers.allan_random_walk.value:.3e}" in line and f"{numbers.random_walk.value:.3e}" in line
        assert "WN+GM+RW" in line and "imu.yaml pastes the final model's" in line


def test_imu_yaml_and_the_report_mark_the_disagreeing_allan_readings(beside_a_gm):
    _, out = beside_a_gm
    doc = yaml.safe_load((out / "imu.yaml").read_text())
    assert doc["gyroscope_random_walk_allan_agrees_xyz"] == [False, False, False]
    assert doc["gyroscope_noise_density_allan_agrees_xyz"] == [True, True, True]
    assert "*_allan_agrees_xyz" in (out / "imu.yaml").read_text()
    html = (out / "report.html").read_text()
    assert html.count("<td class=warn>≠ ") == 3 and "does not overlap" in html  # the three gyro K readings
