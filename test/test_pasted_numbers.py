"""The numbers users paste are built once (``AnalysisResult.numbers``) and every output renders that one object:
``imu.yaml``, the exports, the fleet table, and ``export``'s exports from ``imu.yaml`` parsed back.

Before, ``imu.yaml`` put the Allan-slope reading where a final model had no random walk value while the fleet table
gave no K for that axis, and ``export DIR`` re-derived the Kalibr numbers from string-keyed lists."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from imu_noise_id.batch.unit import fleet_rows
from imu_noise_id.batch.units import Unit
from imu_noise_id.core.axes import AXES, GYRO_AXES
from imu_noise_id.core.noise.components import RW, WN
from imu_noise_id.core.simulation.static import simulate_static_imu
from imu_noise_id.pipelines.analyze import AnalyzeOptions, ModelStage, analyze
from imu_noise_id.report.analysis import write_analysis
from imu_noise_id.report.exports import FORMATS, write_exports
from imu_noise_id.report.imu_yaml import parse_imu_yaml

#: gyros WN + RW, accelerometers WN + RW; fitted as WN alone, so no final model holds a random walk and K is the
#: long-τ Allan variance's bound
MODEL = {a: [WN(1.7e-4), RW(2e-5)] if a in GYRO_AXES else [WN(2e-3), RW(3e-4)] for a in AXES}


@pytest.fixture(scope="module")
def analysed(tmp_path_factory):
    imu = simulate_static_imu(MODEL, 100.0, 300.0, seed=71)
    result = analyze(imu, options=AnalyzeOptions(kinds=("allan",), models=ModelStage("WN"), loop=False, jobs=1))
    out = tmp_path_factory.mktemp("analysis")
    write_analysis(result, out, meta={}, overbound_exports=True)
    return result, out


def test_a_walk_the_final_model_lacks_is_the_same_number_in_imu_yaml_and_the_fleet_table(analysed):
    result, out = analysed
    doc = yaml.safe_load((out / "imu.yaml").read_text())
    rows = {r["axis"]: r for r in fleet_rows(Unit(Path("bag"), None, "bag"), result, [])}
    for sensor, prefix in (("gyro", "gyroscope"), ("accel", "accelerometer")):
        axes = [a for a in AXES if a.startswith(sensor)]
        methods = doc[f"{prefix}_random_walk_method_xyz"]
        assert set(methods) == {"bound"}  # the model has no RW: the largest walk the long-τ AV supports
        for i, axis in enumerate(axes):
            assert rows[axis]["random_walk"] == pytest.approx(doc[f"{prefix}_random_walk_xyz"][i], rel=1e-5)
            assert rows[axis]["random_walk_method"] == methods[i]
            assert rows[axis]["noise_density"] == pytest.approx(doc[f"{prefix}_noise_density_xyz"][i], rel=1e-5)
            assert rows[axis]["random_walk"] == pytest.approx(result.finals[axis].random_walk.value, rel=1e-5)
        assert doc[f"{prefix}_random_walk"] == pytest.approx(max(doc[f"{prefix}_random_walk_xyz"]), rel=1e-5)


def test_export_from_imu_yaml_gives_the_files_analyze_wrote(analysed, tmp_path):
    """imu.yaml parsed back (as ``export DIR`` does) renders every export, and the overbound's, as analyze did."""
    _, out = analysed
    numbers = parse_imu_yaml(yaml.safe_load((out / "imu.yaml").read_text()))
    for overbound in (False, True):
        for path in write_exports(numbers, tmp_path, tuple(FORMATS), overbound=overbound):
            written = (out / "exports" / path.relative_to(tmp_path)).read_text()
            own = "\n".join(ln for ln in written.splitlines() if not ln.startswith("# imu-noise-id run:"))
            assert path.read_text().rstrip("\n") == own.rstrip("\n"), path.name


def test_parsed_numbers_hold_what_was_written(analysed):
    result, out = analysed
    parsed = parse_imu_yaml(yaml.safe_load((out / "imu.yaml").read_text()))
    for sensor in ("gyro", "accel"):
        built, read = result.numbers.sensor(sensor), parsed.sensor(sensor)
        assert read.noise_density == pytest.approx(built.noise_density, rel=1e-5)
        assert read.random_walk == pytest.approx(built.random_walk, rel=1e-5)
        for a, b in zip(built.axes, read.axes, strict=True):
            assert (a.axis, a.random_walk.method, a.random_walk.source) == (b.axis, b.random_walk.method,
                                                                          b.random_walk.source)
            np.testing.assert_allclose(b.random_walk.ci95, a.random_walk.ci95, rtol=1e-5)
    assert parsed.overbound.sensors.keys() == {"gyro", "accel"}


def test_an_imu_yaml_without_a_kalibr_number_is_refused_naming_it():
    from imu_noise_id.core.errors import InputError

    with pytest.raises(InputError, match=r"imu\.yaml lacks gyroscope_random_walk"):
        parse_imu_yaml({"update_rate": 200.0, "gyroscope_noise_density": 1e-4, "accelerometer_noise_density": 1e-3,
                        "accelerometer_random_walk": 1e-4})


def test_the_console_prints_the_numbers_imu_yaml_pastes(analysed):
    from imu_noise_id.report.console import final_table

    result, out = analysed
    doc = yaml.safe_load((out / "imu.yaml").read_text())
    lines: dict[str, str] = {}
    for line in final_table(result.finals, result.static, result.numbers).splitlines()[1:]:
        lines.setdefault(line.split()[0], line)  # an axis's row comes before its notes
    for sensor, prefix in (("gyro", "gyroscope"), ("accel", "accelerometer")):
        for i, axis in enumerate(a for a in AXES if a.startswith(sensor)):
            k = doc[f"{prefix}_random_walk_xyz"][i]
            assert f"K <{k:.3e} [0.000e+00, {k:.3e}]" in lines[axis], lines[axis]  # a bound, as imu.yaml says


def test_each_fleet_row_carries_its_own_axis_warnings_and_the_units(analysed):
    """The fleet table's row of one axis held every axis's warnings ("gyro_x: …" on gyro_y's row): a reader counting
    axes with warnings counted each one six times. Now a row keeps its own axis's and the unit-wide ones."""
    result, _ = analysed
    warnings = ["gyro_x: the random-walk slope is not reached", "accel_z: no white-noise region",
                "not static: gyro_x: the 1 s means vary"]
    rows = {r["axis"]: r for r in fleet_rows(Unit(Path("bag"), None, "bag"), result, warnings)}
    assert rows["gyro_x"]["warnings"] == " | ".join([warnings[0], warnings[2]])
    assert rows["gyro_y"]["warnings"] == warnings[2]
    assert rows["accel_z"]["warnings"] == " | ".join(warnings[1:])


def test_a_bound_above_a_spec_limit_is_undecided_not_failed_and_b_says_how_it_was_read(analysed):
    """Every K here is the long-τ AV's bound (the models have no walk): a bound above the datasheet's limit says the
    record cannot tell, not that the unit fails it (before: ``fail``); below the limit it passes. B's method column
    says whether it is the model's minimum or a bound, as imu.yaml does."""
    from imu_noise_id.report.fleet import COLUMNS, annotate

    result, out = analysed
    doc = yaml.safe_load((out / "imu.yaml").read_text())
    rows = {r["axis"]: r for r in fleet_rows(Unit(Path("bag"), None, "bag"), result, [])}
    assert "bias_instability_method" in COLUMNS
    assert [rows[a]["bias_instability_method"] for a in GYRO_AXES] == doc["gyroscope_bias_instability_method_xyz"]
    walk = rows["gyro_x"]["random_walk"]
    assert rows["gyro_x"]["random_walk_method"] == "bound"
    below, above = (annotate([rows["gyro_x"]], {"gyro": {"random_walk": limit}})[0]["spec"]
                    for limit in (0.5 * walk, 2.0 * walk))
    assert below == "undecided (random_walk)" and above == "pass"
    measured = dict(rows["gyro_x"], random_walk_method="model", random_walk_lo=0.8 * walk)
    assert annotate([measured], {"gyro": {"random_walk": 0.5 * walk}})[0]["spec"] == "fail (random_walk)"


def test_the_report_marks_the_bounds_the_console_marks(analysed):
    """report.html printed a K bound as '4.874e-05 [0, 4.874e-05]' where the console says 'K <4.874e-05 …': the
    numbers-to-paste table now puts '<' before every value that is an upper bound, N and K as pasted."""
    import html

    from imu_noise_id.report.html import fmt

    _, out = analysed
    report = html.unescape((out / "report.html").read_text())
    doc = yaml.safe_load((out / "imu.yaml").read_text())
    for sensor, prefix in (("gyro", "gyroscope"), ("accel", "accelerometer")):
        for i, _ in enumerate(a for a in AXES if a.startswith(sensor)):
            k = doc[f"{prefix}_random_walk_xyz"][i]
            assert f"<td>< {fmt(k)} [0, {fmt(k)}]</td>" in report


def test_the_spec_verdict_names_the_parameter_its_margin_is_of():
    """A unit beyond the datasheet on N by 4 % and on B by 40 % read 'fail (noise_density)' with margin -0.40: the
    verdict named the first failing parameter and the margin was another's. It now names the one furthest beyond."""
    from imu_noise_id.report.fleet import annotate

    row = {"unit": "u", "axis": "gyro_y", "status": "ok", "noise_density": 7.53e-4, "noise_density_hi": 7.6e-4,
           "noise_density_method": "model", "bias_instability": 3.36e-4, "bias_instability_hi": 3.9e-4,
           "bias_instability_method": "model_minimum"}
    got = annotate([row], {"gyro": {"noise_density": 7.2e-4, "bias_instability": 2.0e-4}})[0]
    assert got["spec"] == "fail (bias_instability)" and got["spec_margin"] == pytest.approx(2.0 / 3.36 - 1.0)


def test_an_export_says_which_pasted_walk_is_a_bound_and_whose(analysed, tmp_path):
    """The exports said 'some random walks are not identifiable from the record' without saying which of the numbers
    they hold is a bound: now per sensor, the Kalibr key, the axis it is the maximum of and its method."""
    _, out = analysed
    doc = yaml.safe_load((out / "imu.yaml").read_text())
    text = (out / "exports" / "kalibr_imu_chain.yaml").read_text()
    for sensor, prefix in (("gyro", "gyroscope"), ("accel", "accelerometer")):
        axes = [a for a in AXES if a.startswith(sensor)]
        top = axes[int(np.argmax(doc[f"{prefix}_random_walk_xyz"]))]
        assert f"# Note: {prefix}_random_walk is {top}'s upper bound (bound)" in text
