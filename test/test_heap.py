"""Large freed arrays stay in the heap once :func:`imu_noise_id.heap.keep_freed_memory` ran, until
:func:`~imu_noise_id.heap.release_freed_memory`: read by glibc's own ``mallinfo2``, an independent reader."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys

import pytest

from imu_noise_id.heap import VARIABLES
from imu_noise_id.pipelines.analyze import REUSE_MAX_SAMPLES

pytestmark = pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="the setting is glibc's")

#: glibc's accounting while a 64 MiB array (above its largest mmap threshold) is alive and after it was freed.
PROBE = """
import ctypes, json
import numpy as np
from imu_noise_id.heap import keep_freed_memory, release_freed_memory

class Info(ctypes.Structure):
    _fields_ = [(n, ctypes.c_size_t) for n in ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks",
                                               "fsmblks", "uordblks", "fordblks", "keepcost")]

libc = ctypes.CDLL(None)
libc.mallinfo2.restype = Info
kept = {keep}
a = np.ones(8 * 2**20)
mapped = libc.mallinfo2().hblkhd
del a
free = libc.mallinfo2().fordblks
released = release_freed_memory()
print(json.dumps({{"kept": kept, "mapped": mapped, "free": free, "released": released,
                  "free_after": libc.mallinfo2().fordblks}}))
"""
ARRAY_BYTES = 64 * 2**20


def _probe(tmp_path, keep: bool | str, **extra: str) -> dict:
    path = tmp_path / "probe.py"
    path.write_text(PROBE.format(keep=keep if isinstance(keep, str) else "keep_freed_memory()" if keep else "False"))
    env = {k: v for k, v in os.environ.items() if k not in VARIABLES} | extra
    return json.loads(subprocess.run([sys.executable, str(path)], env=env, check=True, capture_output=True,
                                     text=True, timeout=120).stdout)


def test_a_large_array_comes_from_the_heap_and_stays_there_until_handed_back(tmp_path):
    out = _probe(tmp_path, keep=True)
    assert out["kept"] and out["mapped"] < ARRAY_BYTES and out["free"] >= ARRAY_BYTES
    assert out["released"] and out["free_after"] < out["free"] - ARRAY_BYTES // 2


def test_without_it_glibc_maps_the_array_and_unmaps_it_on_free(tmp_path):
    out = _probe(tmp_path, keep=False)
    assert out["mapped"] >= ARRAY_BYTES and out["free"] < ARRAY_BYTES


def test_an_explicit_setting_wins(tmp_path):
    out = _probe(tmp_path, keep=True, MALLOC_MMAP_MAX_="65536")
    assert out["mapped"] >= ARRAY_BYTES


@pytest.mark.parametrize("n, reused", [(REUSE_MAX_SAMPLES, True), (REUSE_MAX_SAMPLES + 1, False)])
def test_analyze_keeps_them_only_on_records_up_to_its_limit(tmp_path, n, reused):
    """``analyze``'s axis work keeps freed arrays for a record of up to ``REUSE_MAX_SAMPLES`` per axis only."""
    out = _probe(tmp_path, f"__import__('imu_noise_id.pipelines.analyze', fromlist=['_'])._keep_freed_memory({n})")
    assert (out["mapped"] < ARRAY_BYTES) == reused
