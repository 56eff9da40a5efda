"""The command line keeps freed large arrays in the heap (glibc), in itself and in the workers it spawns (``analyze
--jobs``): read by glibc's own ``mallinfo2`` (bytes held in ``mmap``-ed blocks), an independent reader."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys

import pytest

from imu_noise_id.heap import VARIABLES

pytestmark = pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="the setting is glibc's")

#: Bytes in mmap-ed blocks while a 64 MiB array (above glibc's largest mmap threshold) is alive.
PROBE = """
import ctypes, json, multiprocessing
import numpy as np

class Info(ctypes.Structure):
    _fields_ = [(n, ctypes.c_size_t) for n in ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks",
                                               "fsmblks", "uordblks", "fordblks", "keepcost")]

def mapped(_=None):
    libc = ctypes.CDLL(None)
    libc.mallinfo2.restype = Info
    a = np.ones(8 * 2**20)
    return libc.mallinfo2().hblkhd

if __name__ == "__main__":
    {imports}
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        worker = pool.map(mapped, [0])[0]
    print(json.dumps({{"main": mapped(), "worker": worker}}))
"""
ARRAY_BYTES = 64 * 2**20


def _mapped(tmp_path, imports: str, **extra: str) -> dict[str, int]:
    path = tmp_path / "probe.py"
    path.write_text(PROBE.format(imports=imports))
    env = {k: v for k, v in os.environ.items() if k not in VARIABLES} | extra
    out = subprocess.run([sys.executable, str(path)], env=env, check=True, capture_output=True, text=True,
                         timeout=120).stdout
    return json.loads(out)


def test_the_command_line_and_its_workers_take_large_arrays_from_the_heap(tmp_path):
    mapped = _mapped(tmp_path, "import imu_noise_id.cli")
    assert mapped["main"] < ARRAY_BYTES and mapped["worker"] < ARRAY_BYTES


def test_without_the_command_line_glibc_maps_them(tmp_path):
    mapped = _mapped(tmp_path, "pass")
    assert mapped["main"] >= ARRAY_BYTES and mapped["worker"] >= ARRAY_BYTES


def test_an_explicit_setting_wins(tmp_path):
    mapped = _mapped(tmp_path, "import imu_noise_id.cli", MALLOC_MMAP_MAX_="65536")
    assert mapped["main"] >= ARRAY_BYTES and mapped["worker"] >= ARRAY_BYTES


#: The heap's size [bytes] with a freed 64 MiB array kept, then after handing it back.
RELEASE = """
import ctypes, json
import numpy as np
import imu_noise_id.cli
from imu_noise_id.heap import release_freed_memory

class Info(ctypes.Structure):
    _fields_ = [(n, ctypes.c_size_t) for n in ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks",
                                               "fsmblks", "uordblks", "fordblks", "keepcost")]

libc = ctypes.CDLL(None)
libc.mallinfo2.restype = Info
a = np.ones(8 * 2**20)
del a
kept = libc.mallinfo2().fordblks
released = release_freed_memory()
print(json.dumps({"kept": kept, "released": released, "after": libc.mallinfo2().fordblks}))
"""


def test_freed_arrays_stay_in_the_heap_until_handed_back(tmp_path):
    path = tmp_path / "release.py"
    path.write_text(RELEASE)
    env = {k: v for k, v in os.environ.items() if k not in VARIABLES}
    out = json.loads(subprocess.run([sys.executable, str(path)], env=env, check=True, capture_output=True, text=True,
                                    timeout=120).stdout)
    assert out["kept"] >= ARRAY_BYTES
    assert out["released"] and out["after"] < out["kept"] - ARRAY_BYTES // 2
