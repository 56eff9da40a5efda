"""Online identification, one message at a time: the ROS-free logic behind ``imu_noise_id_node`` (``.identifier``)."""

from .config import PARAMETERS, OnlineConfig
from .identifier import OnlineIdentifier
from .results import CorrectedImu, Estimates, HypothesesReport
from .status import ERROR, LEVEL_NAMES, OK, STALE, WARN, DiagnosticStatus

__all__ = [
    "ERROR", "LEVEL_NAMES", "OK", "PARAMETERS", "STALE", "WARN", "CorrectedImu", "DiagnosticStatus", "Estimates",
    "HypothesesReport", "OnlineConfig", "OnlineIdentifier",
]
