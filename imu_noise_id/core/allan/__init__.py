"""The Allan family with χ² intervals, slope parameters and the random-walk bound (docs/analysis.md)."""

from .edf import chi2_interval, edf_greenhall, edf_total, identify_alpha, local_slopes
from .estimators import (
    DEFAULT_CONFIDENCE,
    DEFAULT_PER_DECADE,
    KINDS,
    AllanResult,
    allan_family,
    allan_variance,
    choose_m,
    hadamard_variance,
    max_m,
    modified_allan_variance,
    second_differences,
    stack_axes,
    total_variance,
)

__all__ = [
    "DEFAULT_CONFIDENCE", "DEFAULT_PER_DECADE", "KINDS", "AllanResult", "allan_family", "allan_variance",
    "chi2_interval", "choose_m", "edf_greenhall", "edf_total", "hadamard_variance", "identify_alpha",
    "local_slopes", "max_m", "modified_allan_variance", "second_differences", "stack_axes", "total_variance",
]
