"""``imu-noise-id batch``: the ``analyze`` pipeline over many (bag, IMU topic) units on a Dask cluster.

An adapter like the CLI: it reads bags (:mod:`imu_noise_id.bag`), runs :func:`imu_noise_id.pipelines.analyze.analyze`
and writes with :mod:`imu_noise_id.report`, one unit of work per (bag, IMU topic) (:mod:`.units`, :mod:`.unit`);
:mod:`.runner` submits them to a ``dask.distributed`` client (a local cluster on 127.0.0.1 by default, or an
existing scheduler) and gathers the fleet table; :mod:`imu_noise_id.report.fleet` writes the table and the fleet
report.
"""

from .runner import BatchProgress, BatchResult, open_client, run_batch
from .unit import UnitOutcome, run_unit
from .units import Unit, discover_units

__all__ = ["BatchProgress", "BatchResult", "Unit", "UnitOutcome", "discover_units", "open_client", "run_batch",
           "run_unit"]
