"""bench/run_all.py keeps one section per run in an output file: a rerun replaces its own section only."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

RUN_ALL = Path(__file__).resolve().parents[1] / "bench" / "run_all.py"


def _run_all():
    spec = importlib.util.spec_from_file_location("run_all", RUN_ALL)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_rerun_replaces_its_section_and_keeps_the_others_and_the_note(tmp_path):
    run_all = _run_all()
    out = tmp_path / "bench_x.txt"
    out.write_text("# a note on every run\n\n# python bench/bench_x.py\nquick 1\n\n# python bench/bench_x.py --long\n"
                   "long 1\n")
    run_all.replace_section(out, "# python bench/bench_x.py", "# python bench/bench_x.py\nquick 2\n")
    assert out.read_text() == ("# a note on every run\n\n# python bench/bench_x.py\nquick 2\n\n"
                               "# python bench/bench_x.py --long\nlong 1\n")
    run_all.replace_section(out, "# python bench/bench_x.py --new", "# python bench/bench_x.py --new\nnew\n")
    assert out.read_text().endswith("--long\nlong 1\n\n# python bench/bench_x.py --new\nnew\n")


def test_a_file_without_sections_is_replaced_whole(tmp_path):
    run_all = _run_all()
    out = tmp_path / "bench_x.txt"
    out.write_text("an earlier run's output, written before sections\n")
    run_all.replace_section(out, "# python bench/bench_x.py", "# python bench/bench_x.py\nnow\n")
    assert out.read_text() == "# python bench/bench_x.py\nnow\n"


def test_every_run_of_run_all_has_a_section_in_its_output():
    """The committed outputs are sectioned by the command lines run_all writes, so a rerun replaces them in place."""
    run_all = _run_all()
    for arguments, out in run_all.GOALS + run_all.LONG + run_all.STUDIES:
        _, sections = run_all.split_sections((run_all.RESULTS / out).read_text())
        assert run_all.section_header(arguments) in sections, (out, arguments)


def test_the_results_folder_keeps_one_latest_output_per_benchmark_under_a_stable_name():
    """docs/results/ holds at most 40 files, none named after a commit or a date (git keeps the history)."""
    run_all = _run_all()
    files = [p for p in run_all.RESULTS.rglob("*") if p.is_file()]
    assert len(files) <= 40, sorted(p.name for p in files)
    dated = [p.name for p in files if re.search(r"(^|[_.-])([0-9a-f]{7,40}|\d{4}-\d{2}-\d{2}|before|after)([_.-]|$)",
                                                 p.name)]
    assert not dated, dated


def test_a_runs_section_holds_its_standard_output_and_not_its_progress_on_stderr(tmp_path, monkeypatch, capsys):
    """A benchmark's progress lines and warnings (stderr, unbuffered) went into its committed output ahead of its
    results (stdout, flushed at the end): the section now holds stdout only, stderr is shown on the console."""
    run_all = _run_all()
    (tmp_path / "x.py").write_text("import sys\nprint('result')\nprint('progress', file=sys.stderr)\n")
    monkeypatch.setattr(run_all, "BENCH", tmp_path)
    monkeypatch.setattr(run_all, "RESULTS", tmp_path / "results")
    monkeypatch.setattr(run_all, "GOALS", [(["x.py"], "x.txt")])
    assert run_all.main(["--only", "x.py", "--baseline", str(tmp_path)]) == 0
    assert (tmp_path / "results" / "x.txt").read_text() == "# python bench/x.py\nresult\n"
