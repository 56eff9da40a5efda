"""``imu-noise-id batch`` on a real ``dask.distributed`` local cluster bound to 127.0.0.1 (issue 15)."""

from __future__ import annotations

import dataclasses
import io
import os
import signal
import sys
import threading
import time

import pytest
import yaml

from imu_noise_id.batch import BatchOptions, discover_units, open_client, run_batch
from imu_noise_id.cli import main
from imu_noise_id.core.errors import InputError
from imu_noise_id.pipelines.analyze import AnalyzeOptions, ModelStage

OPTIONS = BatchOptions(AnalyzeOptions(models=ModelStage("WN+RW"), loop=False))
DENSITIES = (1e-3, 2e-3, 4e-3)


@pytest.fixture(scope="module")
def bags(tmp_path_factory):
    """Three simulated static bags with known, different gyro noise densities, and a corrupt one. Their random walks
    are large enough to be identified in 60 s: intervals of a random walk at its zero boundary are profiled, which
    took a third of each unit's time."""
    folder = tmp_path_factory.mktemp("fleet")
    for i, n in enumerate(DENSITIES):
        assert main(["simulate", "--model", f"gyro: WN({n})+RW(1e-3); accel: WN(2e-3)+RW(2e-3)", "--rate", "100",
                     "--duration", "60", "--out", str(folder / f"imu{i}"), "--seed", str(i)]) == 0
    (folder / "broken.mcap").write_bytes(b"not a bag at all")
    return folder


@pytest.fixture(scope="module")
def client():
    with open_client(None, workers=2, memory_limit="2GiB") as c:
        assert all(addr.startswith("tcp://127.0.0.1:") for addr in c.scheduler_info()["workers"])
        yield c


def _kill_a_busy_worker(client, killed: list[str]) -> threading.Thread:
    """A thread that SIGKILLs the first worker seen busy (within 60 s) and records its address in ``killed``."""
    pids = client.run(os.getpid)

    def kill() -> None:
        deadline = time.time() + 60
        while time.time() < deadline and not killed:
            busy = [addr for addr, tasks in client.processing().items() if tasks]
            if busy:
                os.kill(pids[busy[0]], signal.SIGKILL)
                killed.append(busy[0])
            time.sleep(0.05)

    thread = threading.Thread(target=kill)
    thread.start()
    return thread


def test_units_equal_analyze_survive_a_killed_worker_and_a_corrupt_bag_is_one_failed_row(bags, client, tmp_path):
    """One batch run, with a worker killed while it runs a unit: the killed unit is rerun, the table is complete,
    each unit's numbers are analyze's, a corrupt bag is one failed row, and a second run skips what is done."""
    units = discover_units([str(bags / "*")], None)
    killed: list[str] = []
    killer = _kill_a_busy_worker(client, killed)
    result = run_batch(units, OPTIONS, tmp_path, client)
    killer.join()
    assert killed, "no worker was busy to be killed"
    assert len(result.rows) == 3 * 6 + 1 and all(r["noise_density"] > 0 for r in result.rows if r["axis"])
    status = {o.name: o.status for o in result.outcomes}
    assert status == {"broken": "failed", "imu0": "ok", "imu1": "ok", "imu2": "ok"}
    broken = next(o for o in result.outcomes if o.name == "broken")
    assert "broken.mcap" in broken.error and broken.rows[0]["status"] == "failed"
    # each unit's numbers are analyze's on the same bag, with the same options
    assert main(["analyze", str(bags / "imu1"), "--out", str(tmp_path / "direct"), "--model", "WN+RW",
                 "--no-loop"]) == 0
    direct = yaml.safe_load((tmp_path / "direct" / "imu.yaml").read_text())
    rows = {r["axis"]: r for r in result.rows if r["unit"] == "imu1"}
    assert [rows[a]["noise_density"] for a in ("gyro_x", "gyro_y", "gyro_z")] == pytest.approx(
        direct["gyroscope_noise_density_xyz"], rel=1e-5)
    assert rows["gyro_x"]["noise_density"] == pytest.approx(DENSITIES[1], rel=0.05)
    # the unit's own imu.yaml is analyze's: the same numbers to the optimiser's tolerance (a worker's one-thread
    # BLAS sums in another order, which moves a random walk on a flat likelihood within its interval)
    unit_doc = yaml.safe_load((tmp_path / "imu1" / "imu.yaml").read_text())
    for key in ("gyroscope_noise_density_xyz", "accelerometer_noise_density_xyz"):
        assert unit_doc[key] == pytest.approx(direct[key], rel=1e-4)
    for key in ("gyroscope_random_walk", "accelerometer_random_walk"):
        for value, (lo, hi) in zip(unit_doc[f"{key}_xyz"], direct[f"{key}_ci_xyz"], strict=True):
            assert lo <= value <= hi
    # a second run skips the finished units and retries the failed one
    again = run_batch(units, OPTIONS, tmp_path, client)
    assert {o.name: o.status for o in again.outcomes} == {"broken": "failed", "imu0": "skipped", "imu1": "skipped",
                                                           "imu2": "skipped"}
    assert [r for r in again.rows if r["unit"] == "imu0"] == [r for r in result.rows if r["unit"] == "imu0"]



class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_batch_command_writes_the_fleet_table_and_report(bags, client, tmp_path, capsys, monkeypatch):
    """The command on the module's cluster through ``--scheduler`` (the local cluster it would start otherwise is
    ``open_client``'s, which the ``client`` fixture starts)."""
    spec = tmp_path / "spec.yaml"
    spec.write_text("gyro: {noise_density: 3.0e-3}\naccel: {noise_density: 1.0e-2}\n")
    out = tmp_path / "out"
    # the lowest and the highest density: one unit passes the specification, one fails it
    assert main(["batch", str(bags / "imu[02]*"), "--out", str(out), "--model", "WN+RW", "--no-loop", "--spec",
                 str(spec), "--scheduler", client.scheduler.address]) == 0
    import pyarrow.parquet as pq

    table = pq.read_table(out / "fleet.parquet").to_pylist()
    assert len(table) == 12 and {r["unit"] for r in table} == {"imu0", "imu2"}
    verdicts = {r["unit"]: r["spec"] for r in table if r["axis"] == "gyro_x"}
    assert verdicts["imu0"] == "pass" and verdicts["imu2"].startswith("fail")
    assert (out / "fleet.csv").read_text().count("\n") == 13
    report = (out / "fleet_report.html").read_text()
    assert "Against the specification" in report and report.count("data:image/png;base64,") >= 2
    printed = capsys.readouterr().out
    assert "2 of 2 units done" in printed and "2/2 units (0 failed, 0 unchanged and skipped, 0 running" in printed
    # on a terminal: the bar every command draws on stderr, not the log lines (one unit more; the two done skipped)
    tty = _Tty()
    monkeypatch.setattr(sys, "stderr", tty)
    assert main(["batch", str(bags / "imu[012]*"), "--out", str(out), "--model", "WN+RW", "--no-loop", "--spec",
                 str(spec), "--scheduler", client.scheduler.address]) == 0
    assert "batch [" in tty.getvalue() and "(3/3 units)" in tty.getvalue()
    assert "unchanged and skipped" not in capsys.readouterr().out
    assert main(["batch", str(tmp_path / "nothing*"), "--out", str(out)]) == 2
    # a unit that fails: its row and message, the tables written, and exit 1 (it had exited 0 as if all were done)
    assert main(["batch", str(bags / "broken*"), "--out", str(tmp_path / "failing"), "--model", "WN+RW", "--no-loop",
                 "--scheduler", client.scheduler.address]) == 1
    assert "failed: broken" in tty.getvalue() and (tmp_path / "failing" / "fleet.csv").exists()  # stderr: tty


def test_batch_passes_rate_to_every_unit_and_refuses_a_bad_one(bags, tmp_path):
    """``--rate`` as for analyze (the driver's declared rate when the stamps cannot give it), checked before any
    cluster starts."""
    from imu_noise_id.batch.unit import run_unit

    unit = discover_units([str(bags / "imu0*")], None)[0]
    outcome = run_unit(unit, dataclasses.replace(OPTIONS, rate=100.0), str(tmp_path))
    assert outcome.status == "ok", outcome.error
    doc = yaml.safe_load((tmp_path / unit.name / "imu.yaml").read_text())
    assert doc["update_rate"] == 100.0 and "declared (--rate)" in doc["update_rate_source"]
    assert main(["batch", str(bags / "imu0*"), "--out", str(tmp_path / "bad"), "--rate", "-5"]) == 2
    assert not (tmp_path / "bad").exists()


def test_a_unit_long_enough_for_parallel_axes_runs_in_its_dask_worker(client, tmp_path):
    """A record of ≥ PARALLEL_MIN_SAMPLES per axis, where ``analyze`` alone would start a process per axis: in a
    batch its axes run one after another in the worker (a daemonic Dask worker may not start processes)."""
    from imu_noise_id.pipelines.analyze import PARALLEL_MIN_SAMPLES

    duration = PARALLEL_MIN_SAMPLES / 100.0
    assert main(["simulate", "--model", "gyro: WN(1e-3)+RW(2e-5); accel: WN(2e-3)+RW(3e-4)", "--rate", "100",
                 "--duration", f"{duration:g}", "--out", str(tmp_path / "long" / "imu_long"), "--seed", "3"]) == 0
    units = discover_units([str(tmp_path / "long" / "*")], None)
    result = run_batch(units, AnalyzeOptions(models=ModelStage("WN"), loop=False), tmp_path / "out", client)
    assert [o.status for o in result.outcomes] == ["ok"], [o.error for o in result.outcomes]


def test_a_unit_noisier_than_its_spec_late_in_the_record_fails_by_compares_test(tmp_path):
    """gyro_z's density rises 1.6× for the last 80 s of 240 s: its fitted N over the whole record (≈ 1.18e-3) is
    within a 1.3e-3 limit, so the verdict on N alone passed it; the upward CUSUM of ``compare --spec`` (run in the
    unit with ``BatchOptions.limits``) holds it beyond the limit from the change on, and the fleet verdict fails with
    since when. The other gyros stay within."""
    import numpy as np

    from imu_noise_id.bag.writer import write_bag
    from imu_noise_id.batch.unit import run_unit
    from imu_noise_id.batch.units import Unit
    from imu_noise_id.core.axes import AXES, GYRO_AXES, ImuSeries
    from imu_noise_id.core.noise.components import RW, WN
    from imu_noise_id.core.simulation.static import simulate_static_imu
    from imu_noise_id.report.fleet import annotate

    model = {a: [WN(1e-3), RW(1e-5)] if a in GYRO_AXES else [WN(2e-3), RW(1e-4)] for a in AXES}
    imu = simulate_static_imu(model, 100.0, 240.0, seed=5)
    gyro = imu.gyro.copy()
    late = imu.t - imu.t[0] >= 160.0
    gyro[late, 2] += np.random.default_rng(6).standard_normal(int(late.sum())) * 1e-3 * 10.0 * np.sqrt(1.6**2 - 1)
    write_bag(tmp_path / "unit", ImuSeries(imu.t, gyro, imu.accel, imu.frame_id, "/imu/data"))
    options = dataclasses.replace(OPTIONS, limits={"gyro": 1.3e-3})
    outcome = run_unit(Unit(tmp_path / "unit", None, "unit"), options, str(tmp_path / "out"))
    assert outcome.status == "ok", outcome.error
    rows = {r["axis"]: r for r in annotate(outcome.rows, {"gyro": {"noise_density": 1.3e-3}})}
    assert rows["gyro_z"]["noise_density"] < 1.3e-3  # N alone would pass
    assert rows["gyro_z"]["spec"].startswith("fail (noise_density beyond the limit from")
    assert 150.0 <= rows["gyro_z"]["noise_beyond_spec_since_s"] <= 185.0
    assert rows["gyro_z"]["noise_spec_ratio"] > 1.1
    assert rows["gyro_x"]["spec"] == "pass" and rows["gyro_x"]["noise_beyond_spec_since_s"] is None
    assert "noise_spec_ratio" not in rows["accel_x"]


@pytest.mark.parametrize("name", ["fleet.yaml", "bags.txt"])
def test_a_manifest_given_as_a_bag_is_refused_before_any_cluster_starts(tmp_path, capsys, name):
    """A manifest passed where the bags go (``batch fleet.yaml``) had become one unit that failed ("not a bag"), and
    the batch exited 0 with "0 of 1 units done"; it is refused with exit 2 and told to go after --manifest."""
    manifest = tmp_path / name
    manifest.write_text("bags:\n  - path: /nowhere/a.mcap\n" if name.endswith(".yaml") else "/nowhere/a.mcap\n")
    with pytest.raises(InputError, match="--manifest"):
        discover_units([str(manifest)], None)
    assert main(["batch", str(manifest), "--out", str(tmp_path / "out")]) == 2
    assert f"--manifest {manifest}" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_a_globs_files_that_are_not_bags_are_not_units(bags, tmp_path):
    """``batch "fleet/*"`` over bags with a README and a notes file beside them: those are no units (each had been a
    failed one, and the batch's exit code 1); a corrupt file named as a bag still is one, and a file named
    explicitly is not skipped."""
    folder = tmp_path / "fleet"
    folder.mkdir()
    (folder / "imu0").symlink_to(bags / "imu0", target_is_directory=True)
    (folder / "broken.mcap").write_bytes(b"not a bag at all")
    (folder / "README.md").write_text("three IMUs\n")
    (folder / "notes.csv").write_text("unit,place\n")
    assert sorted(u.name for u in discover_units([str(folder / "*")], None)) == ["broken", "imu0"]
    assert [u.name for u in discover_units([str(folder / "notes.csv")], None)] == ["notes"]
    with pytest.raises(InputError, match="no bag among the 1 files it matches"):
        discover_units([str(folder / "*.md")], None)
