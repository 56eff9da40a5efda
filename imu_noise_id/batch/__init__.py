"""``imu-noise-id batch``: the ``analyze`` pipeline over many (bag, IMU topic) units (:mod:`.units`, :mod:`.unit`) on
a ``dask.distributed`` client (:mod:`.runner`); the fleet table and report by :mod:`imu_noise_id.report.fleet`."""

from .runner import BatchProgress, BatchResult, open_client, run_batch
from .unit import UnitOutcome, run_unit
from .units import BatchOptions, Unit, discover_units

__all__ = ["BatchOptions", "BatchProgress", "BatchResult", "Unit", "UnitOutcome", "discover_units", "open_client",
           "run_batch", "run_unit"]
