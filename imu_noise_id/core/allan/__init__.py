"""The Allan family: AV, HV, TV and MDEV with χ² confidence intervals, and slope parameters read off the AV.

* :mod:`.estimators` — the four estimators over τ = m·dt, one signature for all (``allan_family``);
* :mod:`.edf` — their equivalent degrees of freedom (Greenhall & Riley; NIST SP1065) and χ² intervals;
* :mod:`.slopes` — noise density, random walk, quantisation, bias instability and rate ramp from the AV slopes.
"""

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
