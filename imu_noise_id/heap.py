"""The process's heap (glibc only): large freed arrays kept for reuse within a unit of work, handed back after it.

numpy's arrays of a long record (the smoother's states: states × samples doubles, hundreds of MB) are allocated and
freed several times per likelihood evaluation. glibc serves every block above its mmap threshold (at most 32 MB) with
a fresh ``mmap`` and returns it with ``munmap``, so each one is paid again in page faults and zeroed pages.
:func:`keep_freed_memory` keeps such blocks in the heap for reuse: ``mallopt(M_MMAP_MAX, 0)`` (no block served by
``mmap``) and ``mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD)`` (the heap's free top kept up to that size), unless the
environment gives ``MALLOC_MMAP_MAX_`` / ``MALLOC_TRIM_THRESHOLD_`` (an explicit value wins).
:func:`release_freed_memory` (``malloc_trim(0)``) hands the freed memory back to the system after the unit of work.
Only the calling thread's arena gains: other threads allocate from their own arenas, which map such blocks as before.
Both do nothing without glibc. Why, and where ``analyze`` uses them: ``docs/em.md`` ("Freed arrays reused, not mapped
afresh").
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
#: The environment variables glibc reads at a process's start, and the values used without them.
VARIABLES: dict[str, str] = {"MALLOC_MMAP_MAX_": "0", "MALLOC_TRIM_THRESHOLD_": str(TRIM_THRESHOLD)}


def _glibc() -> ctypes.CDLL | None:
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        return None
    return ctypes.CDLL(None)


def keep_freed_memory() -> bool:
    """Set both ``mallopt`` parameters in this process (the environment's values where it gives them); whether glibc
    took them."""
    libc = _glibc()
    if libc is None:
        return False
    mmap_max = int(os.environ.get("MALLOC_MMAP_MAX_", VARIABLES["MALLOC_MMAP_MAX_"]))
    trim = min(int(os.environ.get("MALLOC_TRIM_THRESHOLD_", VARIABLES["MALLOC_TRIM_THRESHOLD_"])), TRIM_THRESHOLD)
    return bool(libc.mallopt(M_MMAP_MAX, mmap_max)) and bool(libc.mallopt(M_TRIM_THRESHOLD, trim))


def release_freed_memory() -> bool:
    """Hand the heap's free memory back to the system (``malloc_trim(0)``); whether any was released."""
    libc = _glibc()
    return bool(libc.malloc_trim(0)) if libc is not None else False
