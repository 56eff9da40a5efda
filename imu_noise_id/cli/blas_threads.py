"""One BLAS thread per process for the command line, set on import, before numpy loads its BLAS.

Importing this module sets each variable of :data:`VARIABLES` to ``1`` unless the environment gives it (inherited by
``--jobs`` and Dask workers); no effect once a BLAS is loaded. Why: ``docs/em.md`` ("One BLAS thread per process").
"""

from __future__ import annotations

import os

#: The thread-count variables of OpenBLAS (numpy's and scipy's wheels), OpenMP and MKL builds.
VARIABLES: tuple[str, ...] = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")

for _name in VARIABLES:
    os.environ.setdefault(_name, "1")
