"""Haar MODWT wavelet variance of one axis at dyadic scales, classical or robust, with per-scale intervals: GMWM
(Guerrier, Skaloud, Stebler & Victoria-Feser, JASA 108, 2013) with the MODWT (Percival & Walden 2000), τ_j = m_j·dt,
m_j = 2^{j−1}, W_{j,t} = (x_{t+2m} − 2x_{t+m} + x_t)/(2m·dt) (x the phase): ν²_j = AV(τ_j)/2, the classical estimator
over M_j = N − 2m_j + 1 coefficients (GMWM eq. 2) half the maximal-overlap AV (paper 000 eq. 2) with half its χ²
intervals; ``robust``: the biweight M-estimator (:mod:`.robust`) after :func:`.robust.hampel_clean`, EDF × its
efficiency."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..allan import AllanResult, allan_variance, chi2_interval, second_differences
from ..constants import CONFIDENCE_95
from ..errors import InputError
from .robust import DEFAULT_EFFICIENCY, BiweightScale, hampel_clean

#: Default longest scale: m_J ≤ this fraction of the record.
DEFAULT_MAX_FRACTION = 1.0 / 8.0
#: Fewest scales a fit may use.
MIN_SCALES = 3
#: The robust WV uses only the coefficients clear of flagged spikes while they are at least this share of all.
MIN_CLEAN_SHARE = 0.25


@dataclass(frozen=True)
class WaveletVariance:
    """The Haar WV of one axis at J dyadic scales: ``dt`` [s], ``n`` samples, ``m`` (J,) factors 2^{j−1}, ``nu2``
    (J,) estimates [u²] with 95 % ``ci_low``, ``ci_high`` and ``edf``, ``robust`` and its ``scale`` M-estimator (or
    None), ``n_replaced`` spikes replaced first."""

    dt: float
    n: int
    m: np.ndarray
    nu2: np.ndarray
    ci_low: np.ndarray
    ci_high: np.ndarray
    edf: np.ndarray
    robust: bool = False
    scale: BiweightScale | None = None
    n_replaced: int = 0

    @property
    def tau(self) -> np.ndarray:
        """Scales τ_j = m_j·dt [s]."""
        return self.m * self.dt

    @property
    def n_coefficients(self) -> np.ndarray:
        """M_j = N − 2m_j + 1 coefficients per scale."""
        return self.n - 2 * self.m + 1

    def as_allan(self) -> AllanResult:
        """The same numbers as a one-column AV (2ν²)."""
        col = lambda a: 2.0 * np.asarray(a, dtype=float)[:, None]  # noqa: E731
        return AllanResult(kind="allan", dt=self.dt, n=self.n, m=self.m, tau=self.tau, variance=col(self.nu2),
                           ci_low=col(self.ci_low), ci_high=col(self.ci_high), edf=self.edf[:, None],
                           alpha=np.zeros((self.m.size, 1), int), confidence=CONFIDENCE_95)

    def select(self, keep: np.ndarray) -> WaveletVariance:
        """The scales where ``keep`` is True."""
        return WaveletVariance(self.dt, self.n, self.m[keep], self.nu2[keep], self.ci_low[keep], self.ci_high[keep],
                               self.edf[keep], self.robust, self.scale, self.n_replaced)


def dyadic_m(n: int, max_fraction: float = DEFAULT_MAX_FRACTION) -> np.ndarray:
    """Averaging factors 1, 2, 4, … up to ``max_fraction``·n; InputError with fewer than :data:`MIN_SCALES`."""
    if not 0.0 < max_fraction <= 0.5:
        raise InputError(f"max_fraction must lie in (0, 0.5], got {max_fraction}")
    j_max = math.floor(math.log2(max(max_fraction * n, 1.0))) + 1
    if j_max < MIN_SCALES:
        raise InputError(f"{n} samples give only {j_max} wavelet scales; at least {MIN_SCALES} are needed "
                         f"(record at least {int(2 ** (MIN_SCALES - 1) / max_fraction)} samples)")
    return 2 ** np.arange(j_max, dtype=np.int64)


def wavelet_variance(y: np.ndarray, dt: float, *, robust: bool = False, efficiency: float = DEFAULT_EFFICIENCY,
                     max_fraction: float = DEFAULT_MAX_FRACTION, m: np.ndarray | None = None) -> WaveletVariance:
    """Haar MODWT WV of finite rate samples ``y`` (N,) [u] at ``dt`` [s], scales to ``max_fraction``·N or factors
    ``m``; ``robust``: the biweight M-estimator of ``efficiency``. InputError on bad or constant samples."""
    y = np.asarray(y, dtype=float)
    if y.ndim != 1:
        raise InputError(f"the wavelet variance takes one axis (1-D samples), got shape {y.shape}")
    m_arr = dyadic_m(y.size, max_fraction) if m is None else np.asarray(m, dtype=np.int64)
    av = allan_variance(y, dt, m=m_arr)  # validates y and dt; its sums are the classical WV (module docstring)
    nu2 = 0.5 * av.variance[:, 0]
    edf = av.edf[:, 0]
    if not np.all(nu2 > 0):
        raise InputError("the signal is constant at some wavelet scale: there is no noise to identify")
    if not robust:
        return WaveletVariance(float(dt), y.size, av.m, nu2, 0.5 * av.ci_low[:, 0], 0.5 * av.ci_high[:, 0], edf)
    scale = BiweightScale.for_efficiency(efficiency)
    cleaned, flagged = hampel_clean(y)
    flagged_before = np.concatenate([[0], np.cumsum(flagged)])
    nu2_rob = np.empty(av.m.size)
    for j, (mm, d) in enumerate(second_differences(cleaned, dt, av.m)):
        # Coefficient i spans samples i .. i + 2m − 1; keep those whose window holds no flagged sample.
        clean = flagged_before[2 * mm:] == flagged_before[:-2 * mm]
        use = d[clean] if clean.sum() >= MIN_CLEAN_SHARE * d.size else d
        nu2_rob[j] = scale.solve(use / (2.0 * mm * dt))
    edf_rob = np.maximum(edf * scale.efficiency, 1.0)
    lo, hi = chi2_interval(nu2_rob, edf_rob, CONFIDENCE_95)
    return WaveletVariance(float(dt), y.size, av.m, nu2_rob, lo, hi, edf_rob, True, scale, int(flagged.sum()))
