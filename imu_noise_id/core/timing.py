"""The sampling period of a series of stamps (one rule for every reader, pipeline and command)."""

from __future__ import annotations

import numpy as np

from .errors import InputError


def sampling_period(t: np.ndarray) -> float:
    """Median interval between consecutive stamps [s].

    Raises
    ------
    InputError
        Fewer than two stamps, non-finite stamps, or a median interval ≤ 0 (stamps not increasing).
    """
    d = np.diff(np.asarray(t, dtype=float))
    if d.size == 0 or not np.all(np.isfinite(d)) or np.median(d) <= 0:
        raise InputError("time stamps must be finite and increasing (need at least 2 samples)")
    return float(np.median(d))
