"""Online identification, one message at a time: the ROS-free logic behind ``imu_noise_id_node``.

The parts, one job each (:class:`OnlineIdentifier` composes them; :mod:`.identifier` lists the per-message steps):

* :mod:`.config` — the node's parameters (names, defaults, ranges, units) and their validation;
* :mod:`.inputs` — receive book-keeping, value checks and saturation of every input stream;
* :mod:`.stamps` — the header-stamp checks: the rate learnt robustly, gaps, outliers, new time lines;
* :mod:`.cmkf_feed` — the CMKF (paper 004 on a robot) behind its stamp merger, restarted on error;
* :mod:`.innovations` — whiteness and consistency of the filters' innovations;
* :mod:`.stationarity` — stationary or moving, with hysteresis and the guard delay line;
* :mod:`.noise` — the white-noise density from stationary samples and the corrected IMU's covariance;
* :mod:`.bank` — the hypothesis bank (paper 002) fed in batches with stationary samples;
* :mod:`.status` — the diagnostics statuses; :mod:`.events` — events for the log, per-period counts;
* :mod:`.results` — the dataclasses returned.
"""

from .config import PARAMETERS, OnlineConfig
from .identifier import OnlineIdentifier
from .results import CorrectedImu, Estimates, HypothesesReport
from .status import ERROR, LEVEL_NAMES, OK, STALE, WARN, DiagnosticStatus

__all__ = [
    "ERROR", "LEVEL_NAMES", "OK", "PARAMETERS", "STALE", "WARN", "CorrectedImu", "DiagnosticStatus", "Estimates",
    "HypothesesReport", "OnlineConfig", "OnlineIdentifier",
]
