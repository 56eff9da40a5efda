"""One story per analysis: the console, the files and the node say the same thing about one result.

The Allan-band claim of the closed loop (report.html, model.yaml, console), identify's decision beside its
probabilities (console, hypotheses.yaml), the CMKF replay's summary naming a counter's cause before a generic one,
and numbers people read printed with sensible digits.
"""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from imu_noise_id.core.noise.components import GM, WN, simulate_sum

DT = 0.01


@pytest.fixture(scope="module")
def partly_outside():
    """A white-noise model left on WN + GM data (the loop not allowed a step): its AV follows the data at short τ
    and falls below them where the GM lives."""
    from imu_noise_id.pipelines.loop import run_closed_loop

    y = simulate_sum([WN(1e-3), GM(1.0, 1e-3)], 20000, DT, np.random.default_rng(5))
    return run_closed_loop(y, DT, "WN", axis="gyro_z", max_steps=0)


def test_the_band_claim_says_where_the_model_leaves_the_band(partly_outside):
    from imu_noise_id.pipelines.av_band import av_band_claim

    claim = av_band_claim(partly_outside)
    assert claim.inside == partly_outside.av_inside_band is False
    assert 0 < claim.n_outside < claim.n_tau
    lo = claim.outside[0][0]
    assert lo > 10 * DT  # inside at the shortest τ, where white noise rules
    sentence = claim.sentence()
    assert "at every τ" not in sentence and "outside" in sentence and "inside it elsewhere" in sentence
    assert f"{lo:.3g}" in sentence


def test_report_model_yaml_and_console_give_the_same_band_sentence(tmp_path, partly_outside):
    from imu_noise_id.pipelines.av_band import av_band_claim
    from imu_noise_id.report.console import loop_line, loop_table
    from imu_noise_id.report.html import loop_axis_section
    from imu_noise_id.report.model_yaml import write_model_yaml

    sentence = av_band_claim(partly_outside).sentence()
    html_text = loop_axis_section("gyro_z", partly_outside)
    assert sentence in html_text.replace("&#x27;", "'")
    assert "at every τ" not in html_text
    doc = yaml.safe_load(write_model_yaml(tmp_path / "model.yaml", {}, {"gyro_z": partly_outside},
                                          {"command": "loop"}).read_text())
    verdict = doc["axes"]["gyro_z"]["loop_verdict"]
    assert verdict["av_band"] == sentence and verdict["av_inside_band"] is False
    assert verdict["av_outside_band_tau"] and verdict["av_outside_band_tau"][0][0] > 10 * DT
    assert sentence in loop_line("gyro_z", partly_outside)
    assert sentence in loop_table({"gyro_z": partly_outside})


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    """identify on a seeded WN+RW gyro record of 60 s: the GM hypothesis wins the raw probabilities but its τ is
    beyond what the record can tell from a random walk, so the decision (on the merged probabilities) is WN+RW."""
    from imu_noise_id.core.axes import ImuSeries
    from imu_noise_id.core.noise.components import RW
    from imu_noise_id.pipelines.identify import identify
    from imu_noise_id.report.hypotheses_yaml import write_identification
    from imu_noise_id.resources import read_hypotheses_file

    out = {}
    for seed, duration in ((0, 60.0), (0, 200.0)):
        n = int(duration / DT)
        rng = np.random.default_rng(seed)
        gyro = np.stack([simulate_sum([WN(1e-3), RW(2e-5)], n, DT, rng) for _ in range(3)], axis=1)
        accel = np.stack([simulate_sum([WN(2e-3), RW(4e-4)], n, DT, rng) for _ in range(3)], axis=1)
        res = identify(ImuSeries(t=np.arange(n) * DT, gyro=gyro, accel=accel), ["gyro_z"], *read_hypotheses_file(None))
        folder = tmp_path_factory.mktemp(f"identify_{seed}_{duration:.0f}")
        write_identification(res, folder)
        out[duration] = (res, yaml.safe_load((folder / "hypotheses.yaml").read_text())["axes"]["gyro_z"])
    return out


@pytest.mark.parametrize("duration", [60.0, 200.0])
def test_identify_probabilities_are_probabilities(identified, duration):
    res, entry = identified[duration]
    for probs in (entry["probabilities"], entry["decision_probabilities"]):
        assert all(0.0 <= p <= 1.0 for p in probs.values())
        assert sum(probs.values()) == pytest.approx(1.0, abs=1e-12)
    rows = res.axes["gyro_z"].result.probabilities
    assert np.all((rows >= 0) & (rows <= 1)) and np.allclose(rows.sum(axis=1), 1.0, atol=1e-12)


@pytest.mark.parametrize("duration", [60.0, 200.0])
def test_a_decision_resting_on_every_hypothesis_merged_is_taken_at_the_records_end(identified, duration):
    """WN+GM merged into WN+RW leaves one merged hypothesis, whose probability is 1 at every update: the decision
    rests on the GM's τ bound over the whole record, not on the first 0.3 s (what it said before)."""
    entry = identified[duration][1]
    merged = {g["hypotheses"][0] for g in entry["indistinguishable"]} | {entry["decision"]}
    assert merged == set(entry["probabilities"])
    assert entry["decision_time_s"] == pytest.approx(entry["duration_s"])


@pytest.mark.parametrize("duration", [60.0, 200.0])
def test_identify_console_line_and_yaml_tell_one_story(identified, duration):
    from imu_noise_id.report.hypotheses_yaml import decision_line

    entry = identified[duration][1]
    line = decision_line("gyro_z", entry)
    # a decision has its time and a time its decision
    assert (entry["decision"] is None) == (entry["decision_time_s"] is None)
    assert entry["decision"] == "WN+RW"
    assert f"decision WN+RW at {entry['decision_time_s']:.3g} s" in line
    for name, p in entry["probabilities"].items():
        assert f"{name} {p:.3f}" in line
    # the raw probabilities favour WN+GM: the line says on what the decision was taken, and why
    assert entry["probabilities"]["WN+GM"] > 0.5
    assert f"P(WN+RW) = {entry['decision_probabilities']['WN+RW']:.3f}" in line
    assert "WN+GM merged into WN+RW" in line and "not identifiable" in line
    assert entry["decision_note"] in line


def test_the_cmkf_summary_names_invalid_orientations_before_a_generic_cause():
    """Every odometry orientation an all-zero quaternion (a driver that publishes none, its twist covariance 100×
    too small) with gravity from the IMU: the filter is not consistent, and the counter that says the odometry is
    not what it claims comes before the generic causes (a mirrored frame, a covariance scale) in the reason and the
    summary's first line."""
    from imu_noise_id.core.axes import ImuSeries, OdometrySeries
    from imu_noise_id.core.cmkf.config import CmkfConfig
    from imu_noise_id.core.simulation.robot import simulate_robot
    from imu_noise_id.pipelines.cmkf_replay import replay, to_yaml_dict

    run = simulate_robot(60.0, np.random.default_rng(2))
    n = len(run.odom_t)
    imu = ImuSeries(run.imu_t, run.gyro, run.accel)
    odom = OdometrySeries(run.odom_t, run.position, np.zeros((n, 4)), run.linear_velocity, run.angular_velocity,
                          run.pose_cov, run.twist_cov * 1e-2)  # and its twist covariance a placeholder
    result = replay(imu, odom, CmkfConfig(imu_rotation_xyzw=run.imu_rotation_xyzw, gravity_source="imu"),
                    np.tile(run.imu_rotation_xyzw, (len(run.imu_t), 1)))
    data = to_yaml_dict(result)
    assert data["counters"]["odom_orientation_invalid"] == n
    reason = data["consistency"]["reason"]
    assert data["consistency"]["verdict"] in ("marginal", "inconsistent")
    assert f"odom_orientation_invalid = {n}" in reason
    generic = [reason.index(g) for g in ("mirrored", "too small", "too large") if g in reason]
    assert generic and reason.index("odom_orientation_invalid") < min(generic)
    assert "odom_orientation_invalid" in data["summary"][0]
    # rates people read: six significant digits (1/median interval gave 100.00000000009095)
    for key in ("imu_rate_hz", "odom_rate_hz"):
        assert data["filter"][key] == float(f"{data['filter'][key]:.6g}")


# -- numbers and options people read ---------------------------------------------------------------------------------

EXPORT_DOC = {"gyroscope_noise_density": 1.7e-4, "gyroscope_random_walk": 2.0e-5,
              "accelerometer_noise_density": 2.0017e-3, "accelerometer_random_walk": 3.0e-4,
              "update_rate": 100.0000000000199, "rostopic": "/imu0"}


def test_export_takes_comma_lists_of_formats(tmp_path):
    from imu_noise_id.cli import main

    (tmp_path / "imu.yaml").write_text(yaml.safe_dump(EXPORT_DOC))
    assert main(["export", str(tmp_path), "--format", "kalibr,px4", "--format", "gtsam"]) == 0
    assert sorted(p.name for p in (tmp_path / "exports").iterdir()) == [
        "gtsam_imu.yaml", "kalibr_imu.yaml", "px4_ekf2.params"]
    assert main(["export", str(tmp_path), "--format", "kalibr,nope"]) == 2


def test_px4_params_are_written_with_seven_significant_digits(tmp_path):
    from imu_noise_id.report.exports import write_exports
    from imu_noise_id.report.imu_yaml import parse_imu_yaml

    text = write_exports(parse_imu_yaml(EXPORT_DOC), tmp_path, ("px4",))[0].read_text()
    rows = {line.split("\t")[2]: line.split("\t")[3] for line in text.splitlines() if not line.startswith("#")}
    assert rows["EKF2_ACC_NOISE"] == "0.020017"  # N / sqrt(10 ms), not 0.020016999999999997 nor 18 decimals
    for value in rows.values():
        assert value == f"{float(value):.7g}"
    assert "100.0000000000199" not in text


def test_simulate_help_lists_every_component_with_its_units():
    from imu_noise_id.cli.simulate import DESCRIPTION
    from imu_noise_id.core.noise.components import COMPONENT_TYPES

    for name, cls in COMPONENT_TYPES.items():
        assert f"{name}(" in DESCRIPTION
        for p in cls.parameter_names:
            assert f"{p}=[{cls.parameter_units[p].replace('*', '·').replace('sqrt(Hz)', '√Hz')}]" in DESCRIPTION
    assert "QN(Q=[u·s])" in DESCRIPTION and "Q=[u])" not in DESCRIPTION



# -- the node: the decision beside the probabilities the monitor shows ---------------------------------------------

def test_the_node_reports_what_its_decision_rests_on_and_when_it_was_made():
    """On a WN+RW record the bank decides WN+RW within seconds by merging the GM hypothesis it cannot tell apart,
    while the raw P(WN+GM) it publishes leads: the report carries the probability the decision rests on, when it
    was made and gamma, and the monitor's line says why the decision differs from the larger raw probability."""
    from imu_noise_id.core.noise.components import RW
    from imu_noise_id.pipelines.online.bank import BankFeed
    from imu_noise_id.pipelines.online.events import EventLog
    from imu_noise_id.resources import read_hypotheses_file
    from imu_noise_id.ros.monitor import MonitorState, render

    feed = BankFeed(*read_hypotheses_file(None), bank_rate=10.0, events=EventLog())
    n, rng = 6000, np.random.default_rng(0)
    y = np.stack([simulate_sum([WN(1e-3), RW(2e-5)], n, DT, rng) for _ in range(6)], axis=1)
    for i in range(n):
        feed.add(i * DT, y[i])
    feed.end_stretch()
    assert feed.feed(1.0 / DT)
    report = feed.report()
    cols, table = report.table()
    k = cols.index("WN+RW")
    i = 2  # gyro_z
    assert table[i, cols.index("decision")] == k
    raw = table[i, k]
    held = table[i, cols.index("decision_probability")]
    made = table[i, cols.index("decision_time_s")]
    gamma = table[i, cols.index("gamma")]
    assert held >= gamma and 0.0 < made <= n * DT
    assert np.all((table[:, :2] >= 0) & (table[:, :2] <= 1))
    text = render(MonitorState(node="/n", hypotheses=(["gyro_x"] * 6, list(cols), table.tolist())))
    lines = text.splitlines()
    header = next(j for j, s in enumerate(lines) if "P(WN+RW)" in s)
    line = next(s for s in lines[header:] if s.startswith("gyro_z"))
    if abs(held - raw) > 5e-4:  # the raw probabilities do not show the decision's: the line says why
        assert f"P {held:.3f}" in line and "merged" in line and f"since {made:.3g} s" in line


def test_the_nodes_decision_resting_on_every_hypothesis_merged_is_as_of_its_latest_update():
    """As identify's: with WN+GM merged into WN+RW the merged probability is 1 at every update, so the decision rests
    on the GM's τ bound over every sample so far; its time is the bank's latest update (was the first feed's end)."""
    from imu_noise_id.core.noise.components import RW
    from imu_noise_id.pipelines.online.bank import BankFeed
    from imu_noise_id.pipelines.online.events import EventLog
    from imu_noise_id.resources import read_hypotheses_file

    feed = BankFeed(*read_hypotheses_file(None), bank_rate=10.0, events=EventLog())
    n, rng = 3000, np.random.default_rng(0)
    y = np.stack([simulate_sum([WN(1e-3), RW(2e-5)], n, DT, rng) for _ in range(6)], axis=1)
    made = []
    for half in (slice(0, n // 2), slice(n // 2, n)):
        for i in range(half.start, half.stop):
            feed.add(i * DT, y[i])
        feed.end_stretch()
        assert feed.feed(1.0 / DT)
        cols, table = feed.report().table()
        assert table[2, cols.index("decision")] == cols.index("WN+RW")
        assert table[2, cols.index("decision_probability")] == pytest.approx(1.0)
        made.append(table[2, cols.index("decision_time_s")])
    assert made[0] == pytest.approx(n // 2 * DT, abs=0.2) and made[1] == pytest.approx(n * DT, abs=0.2)


def test_a_decision_held_by_hysteresis_says_so_with_the_time_it_was_made():
    from imu_noise_id.pipelines.online.results import decision_text

    assert decision_text("WN+RW", raw=0.75, held=0.75, since=12.0, gamma=0.8) == (
        "WN+RW (held: P 0.750 < gamma 0.8 since it was decided at 12 s)")
    assert decision_text("WN+RW", raw=0.39, held=1.0, since=1.0, gamma=0.8) == (
        "WN+RW (P 1.000 with the GM hypothesis it cannot tell apart merged, since 1 s)")
    assert decision_text("WN+RW", raw=0.95, held=0.95, since=3.0, gamma=0.8) == "WN+RW (since 3 s)"
    assert decision_text(None, raw=0.5, held=float("nan"), since=float("nan"), gamma=0.8) == "—"


def test_an_av_outside_the_band_is_not_a_pass(partly_outside):
    """The AV misfit is a residual too: detectors that pass beside a final AV outside the data's band (not within
    the practical error either) end as not passed, and the verdict says what is left unexplained."""
    from imu_noise_id.pipelines.loop.rules import practically_negligible, with_av_misfit

    diag = partly_outside.final.diagnosis
    assert not partly_outside.av_inside_band and not practically_negligible(diag)
    passed, verdict = with_av_misfit(True, "residuals pass: no detector fires at its level", diag)
    assert not passed and verdict.startswith("AV misfit left unexplained") and "largest relative AV error" in verdict
    assert with_av_misfit(False, "nothing improves", diag) == (False, "nothing improves")
