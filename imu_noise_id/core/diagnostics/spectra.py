"""ACF and Welch PSD of standardised innovations (white: |ρ_k| < 1.96/√n, PSD 2·dt [1/Hz])."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal

from .residuals import acf

#: Lags of the autocorrelation and the Welch segment length of the PSD.
ACF_LAGS, WELCH_SEGMENT = 60, 4096


@dataclass(frozen=True)
class ResidualSpectra:
    """ACF (lags 1..L with its ±1.96/√n band) and Welch PSD [1/Hz] of standardised innovations."""

    lags: np.ndarray
    acf: np.ndarray
    band: float
    frequency: np.ndarray
    psd: np.ndarray
    white_level: float


def residual_spectra(e: np.ndarray, dt: float, lags: int = ACF_LAGS) -> ResidualSpectra:
    """Autocorrelation and one-sided Welch PSD of ``e`` (NaN = missing, set to 0 for the PSD) at period ``dt``."""
    ok = np.isfinite(e)
    n = int(ok.sum())
    x = np.where(ok, e, 0.0)
    fs = 1.0 / dt
    f, p = signal.welch(x, fs=fs, nperseg=min(WELCH_SEGMENT, x.size))
    return ResidualSpectra(np.arange(1, lags + 1), acf(e, lags), 1.96 / math.sqrt(n), f[1:], p[1:], 2.0 / fs)
