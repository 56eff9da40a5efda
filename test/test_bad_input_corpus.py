"""The bad-input corpus (issue 12, "Done when"): the CLI over damaged bags, crafted contents and bad options.

Every case runs the real command line in a subprocess and must end with its expected exit code — 2 for input a
user must fix, 0 where the input is usable (with its repair notes) — and **no traceback**. The inputs are small
and generated once; the cases run in one child process (``_DRIVER``: ``imu_noise_id.cli.main`` per case with its
own stderr, an escaping exception printed as a traceback), plus a few as separate ``python -m imu_noise_id``
processes, so that the whole corpus stays well under a minute.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from crafted import bursty_stamps, cut_file, static_imu, with_stamps

from imu_noise_id.bag.writer import write_bag
from imu_noise_id.core.axes import ImuSeries

_DRIVER = r"""
import contextlib, io, json, sys, traceback
from imu_noise_id.cli import main
results = []
for argv in json.load(open(sys.argv[1])):
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse's usage errors
            code = exc.code
        except BaseException:
            traceback.print_exc()
            code = 1
    results.append({"code": code, "err": err.getvalue()})
json.dump(results, open(sys.argv[2], "w"))
"""


def _imu(n: int = 500, rate: float = 100.0) -> ImuSeries:
    return static_imu(rate=rate, duration=n / rate)


def _bag(root: Path, name: str, imu: ImuSeries, **kwargs) -> str:
    return str(write_bag(root / name, imu, **kwargs))


def _corpus(root: Path) -> dict[str, str]:
    """The damaged and crafted inputs, by name."""
    paths: dict[str, str] = {}
    good = _imu()
    paths["good"] = _bag(root, "good", good)
    paths["good_db3"] = _bag(root, "good_db3", good, storage="sqlite3")
    mcap = next((root / "good").glob("*.mcap"))
    (root / "cut").mkdir()
    paths["cut_usable"] = str(cut_file(mcap, root / "cut" / "usable.mcap", 0.7))
    paths["cut_header"] = str(cut_file(mcap, root / "cut" / "header.mcap", 30 / mcap.stat().st_size))
    for name, content in (("empty.mcap", b""), ("garbage.mcap", b"\x89MCAP0\r\n" + bytes(range(256)) * 8),
                          ("garbage.db3", b"SQLite format 3\x00" + b"\xff" * 4000), ("garbage.bag", b"#ROSBAG" * 50),
                          ("notes.txt", b"not a bag")):
        (root / name).write_bytes(content)
        paths[name.replace(".", "_")] = str(root / name)
    (root / "empty_dir").mkdir()
    paths["empty_dir"] = str(root / "empty_dir")

    def crafted(name: str, **changes) -> None:
        imu = _imu()
        for key, fn in changes.items():
            fn(getattr(imu, key))
        paths[name] = _bag(root, name, imu)

    crafted("all_nan", gyro=lambda g: g.__setitem__(slice(None), np.nan))
    crafted("some_nan", gyro=lambda g: g.__setitem__((slice(0, None, 10), 0), np.nan))
    crafted("rare_inf", accel=lambda a: a.__setitem__((3, 1), np.inf))
    crafted("rare_absurd", gyro=lambda g: g.__setitem__((7, 2), 1e10))
    crafted("many_absurd", gyro=lambda g: g.__setitem__((slice(0, 50), 2), 1e10))
    crafted("constant_axis", gyro=lambda g: g.__setitem__((slice(None), 1), 0.0))
    one = _imu()
    paths["one_sample"] = _bag(root, "one_sample", ImuSeries(t=one.t[:1], gyro=one.gyro[:1], accel=one.accel[:1]))
    paths["few_samples"] = _bag(root, "few_samples", ImuSeries(t=one.t[:50], gyro=one.gyro[:50], accel=one.accel[:50]))
    t = good.t.copy()
    t[100:110] = t[100]
    paths["duplicate_stamps"] = _bag(root, "duplicate_stamps", with_stamps(good, t))
    t = good.t.copy()
    t[[200, 201]] = t[[201, 200]]
    t[300] -= 0.5
    paths["backward_stamps"] = _bag(root, "backward_stamps", with_stamps(good, t))
    t = good.t.copy()
    t[250] += 3600.0
    paths["future_stamp"] = _bag(root, "future_stamp", with_stamps(good, t), receive_t=good.t)
    paths["equal_stamps"] = _bag(root, "equal_stamps", with_stamps(good, np.full(len(good), good.t[0])))
    paths["zero_stamps"] = _bag(root, "zero_stamps", with_stamps(good, np.zeros(len(good))), receive_t=good.t)
    slow = static_imu(rate=99.3, duration=20.0)
    stamps = bursty_stamps(slow.t)
    paths["bursty"] = _bag(root, "bursty", with_stamps(slow, stamps), receive_t=stamps + 5e-4)
    paths["bursty_disagree"] = _bag(root, "bursty_disagree", with_stamps(slow, stamps),
                                    receive_t=stamps[0] + (stamps - stamps[0]) * 1.05)
    np.savez(root / "bad.npz", t=np.arange(10.0), gyro=np.zeros((5, 3)), accel=np.zeros((10, 3)))
    paths["bad_npz"] = str(root / "bad.npz")
    (root / "binary.yaml").write_bytes(bytes(range(256)))
    paths["binary_yaml"] = str(root / "binary.yaml")
    return paths


#: (command line with {input} names and {out}, expected exit code)
CASES: list[tuple[str, int]] = [
    # damaged files
    ("inspect {empty_mcap}", 2), ("inspect {garbage_mcap}", 2), ("inspect {garbage_db3}", 2),
    ("inspect {garbage_bag}", 2), ("inspect {notes_txt}", 2), ("inspect {empty_dir}", 2), ("inspect {cut_header}", 2),
    ("inspect {cut_usable}", 0), ("analyze {cut_usable} --model none --out {out}", 0),
    ("analyze {empty_mcap} --out {out}", 2), ("fit {garbage_db3} --model WN --out {out}", 2),
    ("identify {garbage_bag} --out {out}", 2), ("analyze {bad_npz} --out {out}", 2),
    ("analyze /nonexistent/bag --out {out}", 2),
    # crafted contents
    ("inspect {all_nan}", 2), ("analyze {all_nan} --out {out}", 2), ("inspect {some_nan}", 0),
    ("analyze {some_nan} --model none --out {out}", 0), ("inspect {rare_inf}", 0), ("inspect {rare_absurd}", 0),
    ("inspect {many_absurd}", 2), ("analyze {many_absurd} --out {out}", 2), ("inspect {constant_axis}", 0),
    ("analyze {constant_axis} --out {out}", 2), ("inspect {one_sample}", 2), ("analyze {one_sample} --out {out}", 2),
    ("analyze {few_samples} --out {out}", 2), ("identify {few_samples} --out {out}", 2),
    ("inspect {duplicate_stamps}", 0), ("inspect {backward_stamps}", 0), ("inspect {future_stamp}", 0),
    ("analyze {future_stamp} --model none --out {out}", 0), ("inspect {equal_stamps}", 2),
    ("inspect {zero_stamps}", 0), ("inspect {bursty}", 0), ("analyze {bursty} --model none --out {out}", 0),
    ("inspect {bursty_disagree}", 0), ("analyze {bursty_disagree} --model none --out {out}", 2),
    ("fit {bursty_disagree} --model WN --out {out}", 2), ("identify {bursty_disagree} --out {out}", 2),
    ("cmkf {good} --out {out}", 2),
    # bad options
    ("analyze {good} --rate -5 --out {out}", 2), ("analyze {good} --rate nan --out {out}", 2),
    ("inspect {good} --rate 0", 2), ("analyze {good} --topic /nope --out {out}", 2),
    ("analyze {good} --model XYZ --out {out}", 2), ("analyze {good} --confidence 2 --out {out}", 2),
    ("analyze {good} --per-decade 0 --out {out}", 2), ("analyze {good} --out {notes_txt}", 2),
    ("fit {good} --model WN+RW --axis gyro_w --out {out}", 2), ("fit {good} --model RW --out {out}", 2),
    ("identify {good} --hypotheses /nonexistent.yaml --out {out}", 2),
    ("identify {good} --hypotheses {binary_yaml} --out {out}", 2), ("loop {good} --axes foo --out {out}", 2),
    ("loop {good} --start XYZ --out {out}", 2),
    ("simulate --model 'gyro: WN(-1)' --rate 100 --duration 1 --out {out}", 2),
    ("simulate --model 'WN(1e-3)' --rate 0 --duration 1 --out {out}", 2),
    ("criteria --case 1 --trials 1 --out {out}", 2), ("criteria --case 9 --trials 2 --out {out}", 2),
    ("export {notes_txt}", 2), ("analyze", 2), ("frobnicate", 2),
]


def _argv(template: str, paths: dict[str, str], out: Path) -> list[str]:
    import shlex

    return [part.format(**paths, out=str(out)) for part in shlex.split(template)]


@pytest.fixture(scope="module")
def corpus(tmp_path_factory) -> tuple[dict[str, str], Path]:
    root = tmp_path_factory.mktemp("corpus")
    return _corpus(root), root


def test_every_bad_input_is_one_clear_error_and_no_traceback(corpus, ros_env):
    paths, root = corpus
    argvs = [_argv(template, paths, root / f"out{i}") for i, (template, _) in enumerate(CASES)]
    (root / "cases.json").write_text(json.dumps(argvs))
    (root / "driver.py").write_text(_DRIVER)
    subprocess.run([sys.executable, str(root / "driver.py"), str(root / "cases.json"), str(root / "results.json")],
                   env=ros_env, check=True, timeout=300)
    results = json.loads((root / "results.json").read_text())
    wrong = [f"{template!r}: exit {r['code']} (expected {code}); stderr: {r['err'][-500:]}"
             for (template, code), r in zip(CASES, results, strict=True)
             if r["code"] != code or "Traceback" in r["err"]]
    assert not wrong, "\n".join(wrong)
    for (template, code), r in zip(CASES, results, strict=True):
        if code == 2:  # one line naming what to fix (argparse: its usage, then one error line)
            assert r["err"].strip().splitlines()[-1].startswith("imu-noise-id"), (template, r["err"])


@pytest.mark.parametrize("template, code", [("inspect {garbage_mcap}", 2), ("inspect {cut_usable}", 0),
                                            ("analyze {bursty_disagree} --model none --out {out}", 2)])
def test_a_sample_in_their_own_process(corpus, ros_env, template, code):
    paths, root = corpus
    proc = subprocess.run([sys.executable, "-m", "imu_noise_id", *_argv(template, paths, root / "own_out")],
                          capture_output=True, text=True, env=ros_env, timeout=120, check=False)
    assert proc.returncode == code and "Traceback" not in proc.stderr, proc.stderr
