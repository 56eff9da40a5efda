"""One BLAS thread per process for the command line, set on import, before numpy loads its BLAS.

The command line runs its work in parallel itself (``analyze --jobs``, ``batch``'s Dask workers, each a process that
inherits this environment); a BLAS of one thread per core in each of those processes oversubscribes the cores, and
OpenBLAS's threads spin while they wait. Importing this module sets each variable of :data:`VARIABLES` to ``1`` unless
the environment already gives it (an explicit value wins). It has no effect on a process whose BLAS is already loaded.
Why and the measurement: ``docs/em.md`` ("One BLAS thread per process").
"""

from __future__ import annotations

import os

#: The thread-count variables of OpenBLAS (numpy's and scipy's wheels), OpenMP and MKL builds.
VARIABLES: tuple[str, ...] = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")

for _name in VARIABLES:
    os.environ.setdefault(_name, "1")
