"""The report's figures drawn side by side in forked processes (``report/forked.py``): the same files as drawn in turn,
in order, errors raised here (a killed process too), no fork from a process that runs another thread, and Ctrl-C
during the drawing ends the run cleanly."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from concurrent.futures.process import BrokenProcessPool
from functools import partial
from pathlib import Path

import pytest

from imu_noise_id.bag.writer import write_bag
from imu_noise_id.core.noise.modelspec import parse_imu_model
from imu_noise_id.core.simulation.static import simulate_static_imu
from imu_noise_id.pipelines.analyze import AnalyzeOptions, analyze
from imu_noise_id.report.analysis import write_analysis
from imu_noise_id.report.forked import can_fork, run_tasks


def _pid_after(index: int, seconds: float) -> tuple[int, int]:
    time.sleep(seconds)
    return index, os.getpid()


def _fails() -> None:
    raise ValueError("drawn wrong")


@pytest.mark.skipif(not can_fork(), reason="this platform or process cannot fork safely")
def test_tasks_run_in_other_processes_and_return_in_order():
    done = run_tasks([partial(_pid_after, i, 0.05 * (6 - i)) for i in range(6)], processes=2)
    assert [i for i, _ in done] == list(range(6))  # in the tasks' order, though the first finish last
    pids = {pid for _, pid in done}
    assert os.getpid() not in pids and len(pids) == 2


def test_a_tasks_error_is_raised_in_the_caller():
    with pytest.raises(ValueError, match="drawn wrong"):
        run_tasks([partial(_pid_after, 0, 0.0), _fails], processes=2)


def test_with_another_thread_running_nothing_is_forked():
    release = threading.Event()
    other = threading.Thread(target=release.wait)
    other.start()
    try:
        assert not can_fork()
        done = run_tasks([partial(_pid_after, i, 0.0) for i in range(3)], processes=2)
    finally:
        release.set()
        other.join()
    assert {pid for _, pid in done} == {os.getpid()}


@pytest.mark.skipif(not can_fork(), reason="this platform or process cannot fork safely")
def test_the_files_drawn_side_by_side_are_those_drawn_in_turn(tmp_path):
    model = parse_imu_model("gyro: WN(1e-3)+RW(2e-5); accel: WN(2e-3)+RW(3e-4)")
    imu = simulate_static_imu(model, 100.0, 120.0, seed=5)
    result = analyze(imu, None, AnalyzeOptions(jobs=1, axes=("gyro_x", "accel_y")))
    assert result.loops  # the report holds loop sections, the most figures
    in_turn = write_analysis(result, tmp_path / "in_turn", meta={}, processes=1)
    side_by_side = write_analysis(result, tmp_path / "side_by_side", meta={}, processes=2)
    assert set(in_turn) == set(side_by_side) and {"report.html", "allan.png", "allan_model.png"} <= set(in_turn)
    for name, path in in_turn.items():
        assert Path(path).read_bytes() == Path(side_by_side[name]).read_bytes(), name


#: Run in a session of its own by the Ctrl-C test: analyze with its Allan panels held until the test interrupts it.
_HELD_DRAWING = """
import pathlib, sys, time
import imu_noise_id.report.analysis_html as report
def held(result, axis):
    pathlib.Path({mark!r}).touch()
    time.sleep(120)
report._allan_panel = held
from imu_noise_id.cli import main
sys.exit(main(["analyze", {bag!r}, "--model", "WN+RW", "--no-loop", "--jobs", "2", "--out", {out!r}]))
"""


@pytest.mark.skipif(not can_fork(), reason="this platform or process cannot fork safely")
def test_ctrl_c_while_the_figures_are_drawn_leaves_no_folder_no_process_and_no_traceback(tmp_path):
    imu = simulate_static_imu(parse_imu_model("gyro: WN(1e-3)+RW(2e-5); accel: WN(2e-3)+RW(3e-4)"), 50.0, 40.0,
                              seed=3)
    bag = write_bag(tmp_path / "bag", imu)
    mark, out = tmp_path / "drawing", tmp_path / "out"
    child = subprocess.Popen([sys.executable, "-c", _HELD_DRAWING.format(mark=str(mark), bag=str(bag), out=str(out))],
                             start_new_session=True, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not mark.exists():
            assert child.poll() is None and time.monotonic() < deadline, "the drawing never started"
            time.sleep(0.1)
        os.killpg(child.pid, signal.SIGINT)  # as a terminal's Ctrl-C: every process of the group
        assert child.wait(timeout=60) == 130
    finally:
        if child.poll() is None:
            os.killpg(child.pid, signal.SIGKILL)
    assert "Traceback" not in child.stderr.read()
    assert not out.exists() or not [p for p in out.rglob("*") if p.is_file()]
    deadline = time.monotonic() + 10
    while True:  # the drawing processes are gone with their caller
        try:
            os.killpg(child.pid, 0)
        except ProcessLookupError:
            break
        assert time.monotonic() < deadline, "a drawing process outlived its caller"
        time.sleep(0.1)


def _killed() -> None:
    os.kill(os.getpid(), signal.SIGKILL)  # as the kernel's out-of-memory killer would


@pytest.mark.skipif(not can_fork(), reason="this platform or process cannot fork safely")
def test_a_drawing_process_killed_is_an_error_not_a_wait_without_end():
    start = time.monotonic()
    with pytest.raises(BrokenProcessPool):
        run_tasks([partial(_pid_after, 0, 0.0), _killed, partial(_pid_after, 2, 0.0)], processes=2)
    assert time.monotonic() - start < 30
