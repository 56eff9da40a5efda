"""Results folders (issue 12): written atomically, every file stamped with its run, nothing stale left beside it.

Before the fix a rerun overwrote files one by one: another bag's ``model.yaml`` and ``report.html`` stayed beside a
new ``imu.yaml``, and an interrupted run left a complete-looking Allan-only ``imu.yaml``.
"""

from __future__ import annotations

import json
import shutil
import struct
from pathlib import Path

import pytest
import yaml
from crafted import static_imu

from imu_noise_id.bag.writer import write_bag
from imu_noise_id.cli import main
from imu_noise_id.report.results_folder import MANIFEST, STAGING


@pytest.fixture(scope="module")
def two_bags(tmp_path_factory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("bags")
    return (write_bag(root / "a", static_imu(rate=50.0, duration=40.0, seed=1)),
            write_bag(root / "b", static_imu(rate=50.0, duration=40.0, seed=2)))


def _run_of(path: Path) -> dict:
    """The run record a file carries, in its format's way."""
    if path.suffix == ".png":
        data = path.read_bytes()
        pos = 8
        while pos < len(data):
            (n,) = struct.unpack(">I", data[pos : pos + 4])
            if data[pos + 4 : pos + 8] == b"tEXt":
                key, _, text = data[pos + 8 : pos + 8 + n].partition(b"\x00")
                if key == b"imu-noise-id run":
                    return json.loads(text)
            pos += 12 + n
        raise AssertionError(f"{path.name} has no run record")
    text = path.read_text()
    if path.suffix == ".json":
        return json.loads(text)["run"]
    if path.suffix == ".html":
        import html

        start = text.index('<meta name="imu-noise-id-run" content="') + len('<meta name="imu-noise-id-run" content="')
        return json.loads(html.unescape(text[start : text.index('">', start)]))
    if path.name in ("imu.yaml", "model.yaml", "hypotheses.yaml", "cmkf.yaml"):
        return yaml.safe_load(text)["run"]
    line = next(ln for ln in text.splitlines() if ln.startswith("# imu-noise-id run: "))
    return json.loads(line.removeprefix("# imu-noise-id run: "))


def _files(out: Path) -> set[str]:
    return {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()} - {MANIFEST}


@pytest.fixture
def analyzed(golden_run, tmp_path) -> tuple[Path, str]:
    """A copy of the golden run's analyze folder (a default analysis with models) and the bag it read."""
    src = golden_run["analyze_imu.yaml"].parent
    shutil.copytree(src, tmp_path / "out")
    return tmp_path / "out", str(src.parent / "static_bag")


def test_every_file_of_every_command_records_its_run(golden_run):
    """analyze, fit, cmkf, identify and criteria as the golden run ran them."""
    folders = {name: golden_run[key].parent for name, key in (
        ("analyze", "analyze_imu.yaml"), ("fit", "fit_model.yaml"), ("cmkf", "cmkf.yaml"),
        ("identify", "hypotheses.yaml"), ("criteria", "criteria.json"))}
    for command, out in folders.items():
        files = _files(out)
        ids = set()
        for name in files:
            run = _run_of(out / name)
            assert run["command"] == command and run["completed"] is True and run["started"] <= run["finished"]
            ids.add(run["id"])
        assert len(ids) == 1  # one run wrote them all
        manifest = yaml.safe_load((out / MANIFEST).read_text())["runs"]
        assert len(manifest) == 1 and set(manifest[0]["files"]) == files and manifest[0]["run"]["completed"]
        assert not list(out.glob(f"{STAGING}*"))
    analyzed = _files(folders["analyze"])
    assert {"imu.yaml", "model.yaml", "report.html", "allan.csv", "allan.png", "allan_model.png"} <= analyzed
    assert any(f.startswith("exports/") for f in analyzed)
    assert _run_of(folders["analyze"] / "imu.yaml")["options"]["model"] == "auto"


def test_a_report_shows_the_time_of_its_run_record_and_no_clock_of_its_own(golden_run):
    """The report's visible time came from the moment it was rendered: two runs of one bag that finished either side
    of a minute boundary wrote reports differing in more than their run records (a batch and an analyze of one bag
    compared unequal on CI). The reader sees the run's command, id and times, as the run record holds them."""
    report = golden_run["analyze_imu.yaml"].parent / "report.html"
    text, run = report.read_text(), _run_of(report)
    footer = (f"Written by imu-noise-id analyze, run {run['id']}, started {run['started']}, "
              f"finished {run['finished']}.")
    assert footer in text
    assert " UTC" not in text.replace(footer, "")


def test_another_bag_with_other_options_leaves_nothing_of_the_first_run(analyzed, two_bags, capsys):
    out, _ = analyzed
    before = _files(out)
    assert main(["analyze", str(two_bags[1]), "--model", "none", "--out", str(out)]) == 0
    files = _files(out)
    assert "model.yaml" not in files and "report.html" not in files and "allan_model.png" not in files
    assert {_run_of(out / f)["source"] for f in files} == {str(two_bags[1])}
    assert f"removed {len(before - files)} file(s) an earlier run left" in capsys.readouterr().err


def test_a_run_of_another_command_on_the_same_bag_stays_and_one_on_another_bag_does_not(analyzed, two_bags):
    out, bag = analyzed
    before = _files(out)
    assert main(["identify", bag, "--axis", "gyro_x", "--refine", "0", "--no-plot", "--out", str(out)]) == 0
    assert _files(out) == before | {"hypotheses.yaml", "hypotheses_probabilities.csv"}
    assert main(["fit", str(two_bags[1]), "--model", "WN", "--axis", "gyro_x", "--starts", "1",
                 "--out", str(out)]) == 0
    assert _files(out) == {"model.yaml"} and _run_of(out / "model.yaml")["command"] == "fit"


def test_an_interrupted_run_leaves_the_folder_as_it_was(analyzed, two_bags, tmp_path, monkeypatch):
    import imu_noise_id.report.analysis as analysis

    def interrupted(*_args, **_kwargs):
        raise KeyboardInterrupt  # Ctrl-C after imu.yaml and the exports are written

    monkeypatch.setattr(analysis, "write_variance_csvs", interrupted)
    fresh = tmp_path / "fresh"
    assert main(["analyze", str(two_bags[0]), "--model", "none", "--out", str(fresh)]) == 130
    assert _files(fresh) == set()  # no complete-looking Allan-only imu.yaml
    out, _ = analyzed
    before = {f: (out / f).read_bytes() for f in _files(out)}
    assert main(["analyze", str(two_bags[1]), "--model", "none", "--out", str(out)]) == 130
    assert {f: (out / f).read_bytes() for f in _files(out)} == before  # the earlier complete run, untouched
    assert not list(out.glob(f"{STAGING}*")) and not list(fresh.glob(f"{STAGING}*"))


def test_a_killed_runs_staging_is_cleared_and_unaccounted_old_results_are_marked(two_bags, tmp_path, capsys):
    out = tmp_path / "out"
    (out / f"{STAGING}123-4").mkdir(parents=True)  # what kill -9 during the writing leaves
    (out / f"{STAGING}123-4" / "imu.yaml").write_text("partial")
    (out / "report.html").write_text("<html><title>IMU noise analysis: old</title></html>")  # an older version's
    (out / "notes.txt").write_text("the user's own file")
    assert main(["analyze", str(two_bags[0]), "--model", "none", "--out", str(out)]) == 0
    assert not list(out.glob(f"{STAGING}*"))
    assert (out / "report.html.stale").is_file() and not (out / "report.html").exists()
    assert (out / "notes.txt").read_text() == "the user's own file"
    assert "renamed *.stale: report.html" in capsys.readouterr().err
