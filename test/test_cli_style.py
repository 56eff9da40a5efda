"""One CLI style (issue 13): output folders, --axis, --topic, canonical model names, progress, early spec checks,
the recording-length advice. Commands run in-process through ``imu_noise_id.cli.main``."""

from __future__ import annotations

import argparse
import io
import sys

import pytest

from imu_noise_id.cli import build_parser, main
from imu_noise_id.cli.options import default_out, parse_axes
from imu_noise_id.cli.progress import TextProgress
from imu_noise_id.core.errors import InputError


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


@pytest.fixture(scope="module")
def static_bag(tmp_path_factory):
    path = tmp_path_factory.mktemp("bags") / "desk_imu"
    assert main(["simulate", "--model", "gyro: WN(1e-3)+RW(1e-4); accel: WN(2e-3)+RW(4e-4)", "--rate", "50",
                 "--duration", "120", "--out", str(path), "--seed", "2"]) == 0
    return path


def test_default_output_folders_follow_one_scheme():
    assert default_out("analyze", "runs/desk_imu") == default_out("analyze", "runs/desk_imu/")
    assert str(default_out("analyze", "runs/desk_imu/")) == "desk_imu_analyze"
    assert str(default_out("fit", "/data/x.mcap")) == "x_fit"
    assert str(default_out("identify", "old.bag")) == "old_identify"
    assert str(default_out("criteria", None)) == "imu_noise_id_criteria"
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command").choices
    for command in ("analyze", "fit", "loop", "identify", "cmkf"):
        assert f"<BAG stem>_{command}" in sub[command].format_help(), command
    for command in ("criteria", "batch"):
        assert f"imu_noise_id_{command}" in sub[command].format_help(), command


def test_commands_write_into_the_default_folder(static_bag, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["fit", str(static_bag), "--model", "WN+RW", "--axis", "gyro_z", "--starts", "1"]) == 0
    assert (tmp_path / "desk_imu_fit" / "model.yaml").is_file()
    assert main(["criteria", "--case", "2", "--trials", "2", "--duration", "20", "--no-plot"]) == 0
    assert (tmp_path / "imu_noise_id_criteria" / "criteria.json").is_file()
    # a run that fails before writing leaves no empty folder behind
    assert main(["fit", str(tmp_path / "nothing.mcap"), "--model", "WN"]) == 2
    assert not (tmp_path / "nothing_fit").exists()


def test_axis_option_is_repeatable_and_takes_comma_lists():
    assert parse_axes(None) == ["gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"]
    assert parse_axes(["gyro_z,accel_x", "gyro_x", "gyro_z"]) == ["gyro_z", "accel_x", "gyro_x"]
    assert parse_axes(["accel"]) == ["accel_x", "accel_y", "accel_z"]
    with pytest.raises(InputError, match="--axis 'gyro_q': unknown axis"):
        parse_axes(["gyro_x,gyro_q"])
    parser = build_parser()
    for command in ("fit", "loop", "identify"):
        argv = [command, "bag", "--axis", "gyro_x,accel_z", "--axis", "gyro_y"] + (["--model", "WN"] if command ==
                                                                                    "fit" else [])
        assert parse_axes(parser.parse_args(argv).axis) == ["gyro_x", "accel_z", "gyro_y"], command
    assert parser.parse_args(["loop", "bag", "--axes", "gyro_x,gyro_y"]).axis == ["gyro_x,gyro_y"]  # old spelling


def test_one_topic_option_with_hidden_old_spellings():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command").choices
    for command in ("analyze", "fit", "loop", "identify", "cmkf", "inspect"):
        argv = [command, "bag", "--topic", "/imu/a"] + (["--model", "WN"] if command == "fit" else [])
        assert parser.parse_args(argv).topic == "/imu/a", command
    assert parser.parse_args(["batch", "b", "--topic", "/a", "/b"]).topic == ["/a", "/b"]
    # the old spellings still work, and --help shows only --topic
    assert parser.parse_args(["cmkf", "bag", "--imu-topic", "/imu/a"]).topic == "/imu/a"
    assert parser.parse_args(["batch", "b", "--topics", "/a"]).topic == ["/a"]
    assert parser.parse_args(["play", "bag", "--topics", "/a"]).topic == ["/a"]
    for command, old in (("cmkf", "--imu-topic"), ("batch", "--topics"), ("play", "--topics"), ("loop", "--axes")):
        assert old not in sub[command].format_help(), command


def test_model_specs_are_checked_before_any_bag_is_read(tmp_path, monkeypatch, capsys):
    import imu_noise_id.bag.reader as reader

    def no_reading(*args, **kwargs):
        raise AssertionError("the bag was read before the model spec was checked")

    monkeypatch.setattr(reader, "read_static", no_reading)
    monkeypatch.chdir(tmp_path)
    for argv in (["fit", "some.mcap", "--model", "WN+FOO"], ["analyze", "some.mcap", "--model", "WN+FOO"],
                 ["loop", "some.mcap", "--start", "RW+BAR"], ["batch", "some.mcap", "--model", "XX"]):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2
        err = capsys.readouterr().err
        assert "unknown component" in err and "Traceback" not in err, argv
    assert list(tmp_path.iterdir()) == []  # not even the output folder was made


def test_model_names_are_canonical():
    from imu_noise_id.core.hypotheses.criteria import paper_case
    from imu_noise_id.core.hypotheses.model import Hypothesis, ParameterPrior

    assert [h.name for h in paper_case(2, dt=0.1, bias_sigma=1.0).hypotheses] == ["WN+RW", "WN+GM"]
    priors = (ParameterPrior("RW.random_walk", 1e-4, 1e-2, 4), ParameterPrior("WN.noise_density", 1e-3, 1e-2, 4))
    assert Hypothesis(("RW", "WN"), priors).name == "WN+RW"


def test_progress_shows_time_left_and_keeps_printed_lines_apart():
    tty = _Tty()
    bar = TextProgress("fitting", stream=tty, interval=0.0, unit="axes")
    bar(1, 4)
    bar.echo("gyro_x: WN+RW", out=tty)
    bar(4, 4)
    bar.close()
    text = tty.getvalue()
    assert "(1/4 axes)" in text and "left" in text and "100.0 %" in text
    assert "\r\033[Kgyro_x: WN+RW\n" in text  # the bar line cleared before the printed line, redrawn after it


def test_progress_before_the_first_unit_says_when_the_time_left_is_known():
    tty = _Tty()
    bar = TextProgress("model selection", stream=tty, interval=0.0, unit="axes")
    bar(0, 6)
    assert "(0/6 axes)" in tty.getvalue() and "time left known after the first of the 6 axes" in tty.getvalue()
    bar(2, 6)
    assert tty.getvalue().endswith("left\033[K")


@pytest.mark.parametrize("command", ["fit", "loop", "identify", "criteria", "cmkf"])
def test_long_commands_show_progress_on_a_terminal(command, static_bag, tmp_path, monkeypatch, capsys):
    tty = _Tty()
    monkeypatch.setattr(sys, "stderr", tty)
    monkeypatch.chdir(tmp_path)
    if command == "cmkf":
        from golden_run import _robot_bag

        argv = ["cmkf", str(_robot_bag(tmp_path / "robot")), "--imu-rotation", "-1.570796327", "0", "1.570796327",
                "--no-plot"]
        label = "CMKF replay"
    else:
        argv = {"fit": ["fit", str(static_bag), "--model", "WN", "--axis", "gyro_x", "--starts", "1"],
                "loop": ["loop", str(static_bag), "--axis", "gyro_x", "--start", "WN", "--max-steps", "1"],
                "identify": ["identify", str(static_bag), "--axis", "gyro_x", "--no-plot", "--refine", "0"],
                "criteria": ["criteria", "--case", "2", "--trials", "2", "--duration", "20", "--no-plot"]}[command]
        label = {"fit": "fitting WN", "loop": "closed loop from WN", "identify": "hypothesis bank",
                 "criteria": "case 2: 2 trials"}[command]
    assert main(argv) == 0, tty.getvalue()
    text = tty.getvalue()
    assert f"\r{label} [" in text and "100.0 %" in text, text[-400:]


def test_fit_prints_the_recording_length_advice(static_bag, tmp_path, capsys):
    assert main(["fit", str(static_bag), "--model", "WN+RW", "--axis", "gyro_x", "--starts", "1", "--out",
                 str(tmp_path / "f")]) == 0
    out = capsys.readouterr().out
    assert "How long to record" in out and "gyro_x" in out


def test_fit_prints_each_parameter_with_the_interval_model_yaml_holds(static_bag, tmp_path, capsys):
    """`fit` printed the point estimates alone (WN(noise_density=…) RW(random_walk=…)); every estimate is printed
    with its 95 % interval and how it was computed, as model.yaml holds them."""
    import yaml

    out_dir = tmp_path / "f"
    assert main(["fit", str(static_bag), "--model", "WN+RW", "--axis", "gyro_x", "--starts", "1", "--out",
                 str(out_dir)]) == 0
    out = capsys.readouterr().out
    saved = yaml.safe_load((out_dir / "model.yaml").read_text())["axes"]["gyro_x"]["components"]
    for component, parameter in (("WN", "noise_density"), ("RW", "random_walk")):
        c = next(c for c in saved if c["type"] == component)
        lo, hi = c["ci95"]
        line = next(ln for ln in out.splitlines() if f"{component}.{parameter}" in ln)
        assert f"{c[parameter]:.4g} [{lo:.4g}, {hi:.4g}]" in line and c["ci95_method"] in line, line


def test_the_overbound_of_an_axis_not_analysed_says_what_its_factors_are_over(static_bag, tmp_path, capsys):
    """`analyze --axis gyro_x` printed overbound lines for gyro_y and gyro_z too, with inflation factors over values the
    console never gave (their Allan-slope readings, as imu.yaml's ``inflated_over`` says): the line says so."""
    assert main(["analyze", str(static_bag), "--axis", "gyro_x", "--model", "WN+RW", "--no-loop", "--out",
                 str(tmp_path / "a")]) == 0
    lines = capsys.readouterr().out.splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith("Overbound"))
    rows = {ln.split()[0]: ln for ln in lines[start + 1:start + 7] if ln.split() and ln.split()[0] in ("gyro_x",
                                                                                                    "gyro_y")}
    assert "Allan-slope" not in rows["gyro_x"]
    assert "over its Allan-slope readings" in rows["gyro_y"], rows["gyro_y"]


def test_analyze_shows_the_allan_then_the_model_stage_progress(static_bag, tmp_path, monkeypatch):
    tty = _Tty()
    monkeypatch.setattr(sys, "stderr", tty)
    assert main(["analyze", str(static_bag), "--model", "WN+RW", "--no-loop", "--out", str(tmp_path / "a")]) == 0
    text = tty.getvalue()
    assert "\rAllan-family variances [" in text and "\rfitting WN+RW [" in text and "(6/6 axes)" in text
    assert text.index("Allan-family") < text.index("fitting WN+RW")


def test_every_output_folder_option_is_called_out_dir():
    """One spelling across the commands: ``--out DIR`` (export called its folder ``--out OUT`` and its input
    ``source``)."""
    from imu_noise_id.cli import build_parser

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    for name, parser in sub.choices.items():
        outs = [a for a in parser._actions if "--out" in a.option_strings]
        assert all(a.metavar == ("BAG" if name == "simulate" else "DIR") for a in outs), name  # simulate writes a bag
        assert all(a.metavar is not None or a.dest not in ("source",) for a in parser._actions), name


def test_loop_help_names_every_effect_the_loop_adds():
    from imu_noise_id.cli.loop import LOOP_EFFECTS
    from imu_noise_id.pipelines.loop.state import CLEANING_EFFECTS, EXOG_EFFECTS, STATE_EFFECTS

    assert LOOP_EFFECTS == STATE_EFFECTS + EXOG_EFFECTS + CLEANING_EFFECTS
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    loop_help = next(c.help for c in sub._choices_actions if c.dest == "loop")
    assert all(effect in loop_help for effect in LOOP_EFFECTS)
