"""The process's heap (glibc only): large freed arrays kept for reuse within a unit of work, handed back after it.

numpy's arrays of a long record (the smoother's states: states × samples doubles, hundreds of MB) are allocated and
freed several times per likelihood evaluation. glibc serves every block above its mmap threshold (at most 32 MB) with
a fresh ``mmap`` and returns it with ``munmap``, so each one is paid again in page faults and zeroed pages.
:func:`keep_freed_memory` keeps such blocks in the heap for reuse: ``mallopt(M_MMAP_MAX, 0)`` (no block served by
``mmap``) and ``mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD)`` (the heap's free top kept up to that size) in this
process, and the same as ``MALLOC_MMAP_MAX_`` / ``MALLOC_TRIM_THRESHOLD_`` in the environment the processes it starts
inherit (``analyze --jobs`` workers, Dask workers) unless the environment gives them (an explicit value wins).
:func:`release_freed_memory` (``malloc_trim(0)``) hands the freed memory back to the system, e.g. after an axis, so a
process does not stay at its peak while it works on the next. Threads other than a process's main thread allocate
from their own arenas, which fall back to ``mmap`` for such blocks as before. Both do nothing without glibc. Why and
what it buys: ``docs/em.md`` ("Freed arrays reused, not mapped afresh").
"""

from __future__ import annotations

import ctypes
import os
import platform

#: glibc's ``mallopt`` parameters (malloc.h).
M_TRIM_THRESHOLD = -1
M_MMAP_MAX = -4
#: Largest free top of the heap kept [bytes] (``mallopt`` takes an int).
TRIM_THRESHOLD = 2**31 - 1
#: The environment variables glibc reads at a process's start, and their values.
VARIABLES: dict[str, str] = {"MALLOC_MMAP_MAX_": "0", "MALLOC_TRIM_THRESHOLD_": str(TRIM_THRESHOLD)}


def _glibc() -> ctypes.CDLL | None:
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        return None
    return ctypes.CDLL(None)


def keep_freed_memory() -> bool:
    """Set both ``mallopt`` parameters in this process and the variables for its children; whether glibc took them."""
    libc = _glibc()
    if libc is None:
        return False
    for name, value in VARIABLES.items():
        os.environ.setdefault(name, value)
    mmap_max = int(os.environ["MALLOC_MMAP_MAX_"])
    trim = min(int(os.environ["MALLOC_TRIM_THRESHOLD_"]), TRIM_THRESHOLD)
    return bool(libc.mallopt(M_MMAP_MAX, mmap_max)) and bool(libc.mallopt(M_TRIM_THRESHOLD, trim))


def release_freed_memory() -> bool:
    """Hand the heap's free memory back to the system (``malloc_trim(0)``); whether any was released."""
    libc = _glibc()
    return bool(libc.malloc_trim(0)) if libc is not None else False
