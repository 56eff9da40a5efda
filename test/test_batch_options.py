"""``batch`` takes ``analyze``'s options (one argparse helper, one :class:`AnalyzeOptions`), ships them to its Dask
units as they are and hashes them for resuming; a bag's files from ``batch`` are ``analyze``'s."""

from __future__ import annotations

import dataclasses
import os
import pickle
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from imu_noise_id.batch import BatchOptions, Unit, open_client
from imu_noise_id.batch.units import content_hash
from imu_noise_id.cli import build_parser, main
from imu_noise_id.cli.options import analysis_options
from imu_noise_id.core.estimation.em.model import FitOptions
from imu_noise_id.core.estimation.gmwm.fit import GmwmOptions
from imu_noise_id.core.noise.digital import SensorFilter
from imu_noise_id.pipelines.analyze import AnalyzeOptions, ModelStage

#: analyze's options that batch spells differently or leaves out, and why: the bag is batch's BAG_OR_GLOB…;
#: ``--topic`` takes several topics (default: every IMU topic of each bag); ``--out`` defaults to one folder for the
#: batch; ``--jobs``: batch runs its units side by side on its workers, each unit's axes one after another.
NOT_SHARED = ("bag", "--topic", "--out", "--jobs")
#: Non-default values of every analysis option, on the command line and as the options they must give.
ARGV = ["--per-decade", "6", "--confidence", "0.9", "--model", "WN+RW", "--estimator", "both", "--robust",
        "--allow-motion", "--span", "5:295", "--horizon", "40", "--no-loop", "--sensor-filter", "42:2"]
EXPECTED = AnalyzeOptions(per_decade=6, confidence=0.9, allow_motion=True,
                          models=ModelStage("WN+RW", estimator="both", gmwm=GmwmOptions(robust=True),
                                            sensor_filter=SensorFilter(42.0, 2)),
                          loop=False, horizon_s=40.0, jobs=1, span=(5.0, 295.0))


def _subparsers() -> dict:
    parser = build_parser()
    return next(a for a in parser._actions if a.dest == "command").choices


def _actions(parser) -> dict:
    return {(a.option_strings[0] if a.option_strings else a.dest): a for a in parser._actions if a.dest != "help"}


def test_batch_accepts_every_analyze_option_with_the_same_flags_defaults_and_help():
    commands = _subparsers()
    analyze, batch = _actions(commands["analyze"]), _actions(commands["batch"])
    shared = [name for name in analyze if name not in NOT_SHARED]
    assert {"--estimator", "--horizon", "--span", "--robust", "--confidence", "--overbound", "--rate",
            "--sensor-filter"} <= set(shared)
    for name in shared:
        a, b = analyze[name], batch.get(name)
        assert b is not None, f"batch lacks {name}"
        for attr in ("option_strings", "dest", "default", "help", "choices", "nargs", "const", "metavar", "required"):
            assert getattr(a, attr) == getattr(b, attr), (name, attr)
        assert type(a) is type(b) and getattr(a.type, "__name__", a.type) == getattr(b.type, "__name__", b.type)
    # one helper turns them into the same AnalyzeOptions for both commands
    for command in ("analyze", "batch"):
        args = build_parser().parse_args([command, "some.mcap", *ARGV])
        assert analysis_options(args, jobs=1) == EXPECTED


def test_options_pickle_and_every_option_changes_the_resume_key(tmp_path):
    """The options travel to the workers by pickle and give the same key in any process; each option, changed
    alone, gives another key."""
    bag = tmp_path / "imu.mcap"
    bag.write_bytes(b"the bytes of a bag")
    unit = Unit(bag, "/imu/data", "imu")
    options = BatchOptions(EXPECTED, rate=100.0)
    again = pickle.loads(pickle.dumps(options))
    assert again == options and again.as_dict() == options.as_dict()
    assert BatchOptions(AnalyzeOptions(jobs=0)).analysis.jobs == 1  # a Dask worker runs a unit's axes itself
    key = content_hash(unit, options)
    script = ("import pickle, sys; from imu_noise_id.batch.units import content_hash; "
              "print(content_hash(*pickle.loads(sys.stdin.buffer.read())))")
    other = subprocess.run([sys.executable, "-c", script], input=pickle.dumps((unit, options)), capture_output=True,
                           check=True, env={**os.environ, "PYTHONHASHSEED": "1"})
    assert other.stdout.decode().strip() == key
    assert content_hash(unit, BatchOptions(dataclasses.replace(EXPECTED), rate=100.0)) == key
    models = EXPECTED.models
    changed = {
        "per_decade": dataclasses.replace(EXPECTED, per_decade=7),
        "confidence": dataclasses.replace(EXPECTED, confidence=0.95),
        "allow_motion": dataclasses.replace(EXPECTED, allow_motion=False),
        "model": dataclasses.replace(EXPECTED, models=dataclasses.replace(models, model="WN+GM+RW")),
        "estimator": dataclasses.replace(EXPECTED, models=dataclasses.replace(models, estimator="em")),
        "robust": dataclasses.replace(EXPECTED, models=dataclasses.replace(models, gmwm=GmwmOptions())),
        "sensor_filter": dataclasses.replace(EXPECTED,
                                             models=dataclasses.replace(models, sensor_filter=SensorFilter(42.0))),
        "loop": dataclasses.replace(EXPECTED, loop=True),
        "horizon": dataclasses.replace(EXPECTED, horizon_s=41.0),
        "span": dataclasses.replace(EXPECTED, span=(5.0, float("inf"))),
    }
    keys = {name: content_hash(unit, BatchOptions(analysis, rate=100.0)) for name, analysis in changed.items()}
    keys["rate"] = content_hash(unit, BatchOptions(EXPECTED))
    keys["overbound"] = content_hash(unit, BatchOptions(EXPECTED, rate=100.0, overbound_exports=True))
    assert key not in keys.values() and len(set(keys.values())) == len(keys)


@pytest.fixture(scope="module")
def bag(tmp_path_factory) -> Path:
    """5 min at 100 Hz, static."""
    folder = tmp_path_factory.mktemp("one_bag")
    assert main(["simulate", "--model", "gyro: WN(1e-3)+RW(1e-4); accel: WN(2e-3)+RW(3e-4)", "--rate", "100",
                 "--duration", "300", "--out", str(folder / "imu5"), "--seed", "7"]) == 0
    return folder / "imu5"


@pytest.fixture(scope="module")
def client():
    with open_client(None, workers=1, memory_limit="2GiB") as c:
        assert all(addr.startswith("tcp://127.0.0.1:") for addr in c.scheduler_info()["workers"])
        yield c


def test_a_changed_option_reruns_a_unit_and_unchanged_ones_resume(bag, client, tmp_path):
    out = tmp_path / "out"
    base = ["batch", str(bag), "--out", str(out), "--model", "none", "--span", "0:120", "--scheduler",
            client.scheduler.address]

    def run(*extra: str) -> str:
        """The id of the run that wrote the unit's files."""
        assert main([*base, *extra]) == 0
        return yaml.safe_load((out / bag.name / "imu.yaml").read_text())["run"]["id"]

    first = run()
    assert run() == first  # resumed: nothing ran again
    horizon = run("--horizon", "50")
    assert horizon != first and '"horizon_s": 50.0' in (out / bag.name / "unit.json").read_text()
    assert run("--horizon", "50") == horizon
    assert run("--horizon", "50", "--estimator", "em") != horizon


#: What legitimately differs between analyze's and batch's files for one bag, removed before comparing:
#: the run record each file is stamped with (run id, command, argv, the options as each command records them,
#: start and finish times): the ``run:`` block of imu.yaml and model.yaml, the ``# imu-noise-id run:`` line of CSV
#: files and exports, the ``imu-noise-id-run`` meta element and the visible run paragraph of report.html;
RUN_BLOCK = re.compile(r"^run:\n(?:[ -].*\n)*", re.MULTILINE)
RUN_LINE = re.compile(r"^# imu-noise-id run: .*\n", re.MULTILINE)
RUN_META = re.compile(r'<meta name="imu-noise-id-run" content="[^"]*">')
RUN_FOOTER = re.compile(r"<p class=small id=run>Written by imu-noise-id [^<]*</p>")
#: and the name of the command that wrote them: model.yaml's ``meta: command:``, report.html's run table cell.
COMMAND = (re.compile(r"^  command: (analyze|batch)$", re.MULTILINE), re.compile(r"<td class=l>(analyze|batch)</td>"))
#: Files only one of them writes: analyze's results-folder manifest, batch's unit marker (hash, options, rows).
OWN_FILES = {"imu_noise_id_runs.yaml", "unit.json"}


def _normalised(text: str) -> str:
    for pattern in (RUN_BLOCK, RUN_LINE, RUN_META, RUN_FOOTER, *COMMAND):
        text = pattern.sub("", text)
    return text


def _files(root: Path) -> set[str]:
    return {p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file()} - OWN_FILES


def test_one_bag_through_analyze_and_batch_gives_the_same_files(bag, client, tmp_path):
    """The same non-default options on both; analyze in a process with one BLAS thread, as Dask gives its workers
    (another summation order moves the last digits of a fit), side by side with the batch."""
    options = ["--per-decade", "6", "--model", "WN+RW", "--estimator", "both", "--span", "5:295", "--horizon", "40",
               "--overbound"]
    direct, batched = tmp_path / "direct", tmp_path / "batched"
    analyze = subprocess.Popen([sys.executable, "-m", "imu_noise_id", "analyze", str(bag), "--out", str(direct),
                                *options], env={**os.environ, "OPENBLAS_NUM_THREADS": "1"},
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        assert main(["batch", str(bag), "--out", str(batched), *options, "--scheduler",
                     client.scheduler.address]) == 0
    finally:
        _, err = analyze.communicate(timeout=300)
    assert analyze.returncode == 0, err.decode()
    unit = batched / bag.name
    names = _files(direct)
    assert names == _files(unit)
    assert {"imu.yaml", "model.yaml", "report.html", "allan.csv", "allan.png", "exports/overbound/kalibr_imu.yaml"} \
        <= names
    assert "overbound:" in (direct / "imu.yaml").read_text()
    for name in sorted(names):
        if name.endswith(".png"):  # figures: by existence (each carries its run record in a tEXt chunk)
            continue
        a, b = (direct / name).read_text(), (unit / name).read_text()
        assert _normalised(a) == _normalised(b), name
        assert a != _normalised(a), f"{name}: no run record removed"  # every file is stamped with its run


#: Options ``fit`` and ``loop`` spell or default their own way (the model is required by ``fit`` and the start of
#: ``loop``; ``fit`` offers the two estimators its single fit can be, ``em`` by default), beside those only
#: ``analyze`` and ``batch`` have (the Allan stage's grid, the overbound, --no-loop) and ``fit``'s lack of a loop.
OWN = {"fit": ("--model", "--estimator", "--per-decade", "--confidence", "--horizon", "--overbound", "--no-loop",
               "--temperature-topic", "--alpha", "--max-steps"),
       "loop": ("--model", "--estimator", "--per-decade", "--confidence", "--horizon", "--overbound", "--no-loop")}


def test_fit_and_loop_are_analyze_with_stages_selected_and_share_its_options():
    commands = _subparsers()
    analyze = _actions(commands["analyze"])
    for command, own in OWN.items():
        actions = _actions(commands[command])
        for name, a in analyze.items():
            if name in ("bag", "--out") or name in own:  # --out: each command's default folder name
                continue
            b = actions.get(name)
            assert b is not None, f"{command} lacks {name}"
            for attr in ("dest", "default", "help", "choices", "metavar"):
                assert getattr(a, attr) == getattr(b, attr), (command, name, attr)
    fit = analysis_options(build_parser().parse_args(["fit", "b.mcap", "--model", "WN+GM", "--axis", "gyro_z",
                                                      "--starts", "2", "--span", "5:295"]))
    assert fit == AnalyzeOptions(kinds=("allan",), models=ModelStage("WN+GM", FitOptions(n_starts=2),
                                                                     estimator="em", gmwm=GmwmOptions(n_starts=2)),
                                 axes=("gyro_z",), loop=False, finals=False, span=(5.0, 295.0))
    loop = analysis_options(build_parser().parse_args(["loop", "b.mcap", "--start", "WN", "--axes", "gyro_x",
                                                       "--alpha", "0.05", "--max-steps", "2"]))
    assert loop == AnalyzeOptions(models=ModelStage("WN", estimator="em"), axes=("gyro_x",), loop=True,
                                  loop_alpha=0.05, loop_max_steps=2)
