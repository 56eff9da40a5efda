"""``analyze`` refuses, before decoding, a record this machine's memory cannot hold, with the need and a --span that
fits; what is available is read from /proc/meminfo and the cgroup's limit."""

from __future__ import annotations

import numpy as np
import pytest

from imu_noise_id.cli import main, memory
from imu_noise_id.core.errors import InputError


def test_available_memory_is_the_smaller_of_meminfo_and_the_cgroups_room(tmp_path):
    meminfo = tmp_path / "meminfo"
    meminfo.write_text("MemTotal:       24000000 kB\nMemAvailable:   20000000 kB\n")
    cgroup = tmp_path / "cgroup"
    cgroup.mkdir()
    assert memory.available_bytes(meminfo, cgroup) == 20000000 * 1024.0
    (cgroup / "memory.max").write_text("max\n")
    assert memory.available_bytes(meminfo, cgroup) == 20000000 * 1024.0
    (cgroup / "memory.max").write_text(f"{8 * 2**30}\n")
    (cgroup / "memory.current").write_text(f"{2 * 2**30}\n")
    assert memory.available_bytes(meminfo, cgroup) == 6 * 2**30
    assert memory.available_bytes(tmp_path / "none", tmp_path / "none") is None


def test_a_record_beyond_the_memory_is_refused_with_a_span_that_fits():
    """24 h at 400 Hz with two workers on 8 GiB: refused, with the need and a --span whose own need fits (the span
    asked for is what counts); 1 h fits; on 4 GiB the whole record's decoding alone is too much: split the bag."""
    n, room = 24 * 3600 * 400, 8 * 2**30
    with pytest.raises(InputError, match=r"/imu: analysing 34560000 samples .* GiB .*--span 0:\d+") as refused:
        memory.check_fits("/imu", n, 86400.0, span=None, workers=2, available=room)
    seconds = float(str(refused.value).split("--span 0:")[1].split(" ")[0])
    assert 0 < seconds < 86400
    assert memory.needed_bytes(n, int(seconds * 400), 2) <= room < memory.needed_bytes(n, n, 2)
    memory.check_fits("/imu", n, 86400.0, span=(0.0, seconds), workers=2, available=room)
    memory.check_fits("/imu", 3600 * 400, 3600.0, span=None, workers=2, available=room)
    memory.check_fits("/imu", n, 86400.0, span=None, workers=2, available=None)  # not Linux: no check
    with pytest.raises(InputError, match="split the bag"):
        memory.check_fits("/imu", n, 86400.0, span=(0.0, 60.0), workers=2, available=4 * 2**30)


def test_analyze_refuses_before_decoding_and_leaves_no_folder(tmp_path, capsys, monkeypatch):
    bag = tmp_path / "imu"
    assert main(["simulate", "--model", "WN(1e-3)+RW(1e-5)", "--rate", "100", "--duration", "60", "--out", str(bag),
                 "--seed", "2"]) == 0
    monkeypatch.setattr(memory, "available_bytes", lambda: 1.0 * 2**20)
    out = tmp_path / "out"
    assert main(["analyze", str(bag), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "/imu/data: analysing 6000 samples" in err and "GiB" in err and "Traceback" not in err
    assert not out.exists()


def test_the_need_of_a_record_the_loop_analyses_covers_a_measured_one():
    # A whole ADIS16405 run (10^6 samples per axis at 100 Hz, two workers): the process tree peaked at 3915 MiB of
    # PSS (docs/results/bench_analyze_time.txt), where the model of GMWM-length records had said 0.6 GiB: the
    # loop's smoother passes hold every state of its models (up to 25 there) for every sample.
    need = memory.needed_bytes(10**6, 10**6, 2)
    assert 3915 * 2**20 <= need <= 2 * 3915 * 2**20
    # beyond the EM's length the GMWM's smaller need holds, and a --span advice stays at a length that fits
    assert memory.worker_bytes_per_sample(memory.EM_MAX_SAMPLES + 1) < memory.worker_bytes_per_sample(10**6)
    # the advised span fits whatever the room (it was rounded to the nearest second, and a span's end adds a sample:
    # at 6.0 GiB the advice did not fit)
    for room in np.linspace(5.0, 7.0, 41) * 2**30:
        with pytest.raises(InputError, match=r"--span 0:\d+ fits") as refused:
            memory.check_fits("/imu", 4 * 10**6, 40_000.0, span=None, workers=2, available=room)
        seconds = float(str(refused.value).split("--span 0:")[1].split(" ")[0])
        memory.check_fits("/imu", 4 * 10**6, 40_000.0, span=(0.0, seconds), workers=2, available=room)
