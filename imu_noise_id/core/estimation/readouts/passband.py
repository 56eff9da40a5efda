"""The data's passband level N² from the record's spectrum, in the band where a fitted model says the noise N reads
(white noise and the sensor's filter, :func:`~.kalibr.enters_n`) dominates: a reading of N whose value the model's
structure does not decide (it only chooses the band and the filter's gain across it).

With S(f) the two-sided Welch PSD of the record (Hann segments of :data:`WELCH_SEGMENT` samples, 50 % overlap), W(f)
the PSD of the components entering N, W(0) = N_model², and O(f) the PSD of the others, the band is where
W ≥ :data:`WHITE_SHARE`·(W + O) and W/W(0) lies within :data:`WHITE_SHARE` of 1 (the filter's flat passband); each bin
gives (S − O)·W(0)/W, an estimate of the data's N², and their mean is the level. Its variance: 1.056·S²/K per bin
for K segments (Hann, 50 % overlap: ν ≈ 36K²/(19K − 1) degrees of freedom, Percival & Walden 1993, sec. 6.17), bins
one and two apart correlated (:data:`ADJACENT_BIN_FACTOR`); the interval is in log space.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal

from ...noise.base import Component
from ...noise.components import RR
from ...quality import interpolate_missing
from .kalibr import enters_n
from .quantiles import Z95

#: Welch segment [samples] (fewer on short records: an eighth of the record).
WELCH_SEGMENT = 4096
#: The band: the N components hold this share of the model's PSD, and their PSD is within this of its 0 Hz value.
WHITE_SHARE = 0.9
#: Fewest bins a level is read from.
MIN_BINS = 8
#: Variance of a sum of B Hann-windowed periodogram bins over B times one bin's, white noise: the squared window's
#: transform one and two bins off is −2/3 and 1/6 of its peak, so |ρ|² = 4/9 and 1/36, and B(1 + 2(4/9 + 1/36)).
ADJACENT_BIN_FACTOR = 1.0 + 2.0 * (4.0 / 9.0 + 1.0 / 36.0)
#: Variance of one Welch bin (Hann, 50 % overlap) over S²/K for K segments.
WELCH_VARIANCE_FACTOR = 1.056


@dataclass(frozen=True)
class PassbandLevel:
    """The data's N [u/√Hz] with its 95 % interval ``ci`` (lo, hi), read over ``band_hz`` (lo, hi) from ``bins``
    Welch bins; ``method`` is ``"spectrum"``."""

    value: float
    ci: tuple[float, float]
    band_hz: tuple[float, float]
    bins: int
    method: str = "spectrum"

    def describe(self) -> str:
        return (f"the record's spectrum over {self.band_hz[0]:.3g}–{self.band_hz[1]:.3g} Hz, "
                f"{self.value:.3g} [{self.ci[0]:.3g}, {self.ci[1]:.3g}]")


def passband_level(y: np.ndarray, dt: float, components: list[Component]) -> PassbandLevel | None:
    """The data's passband level (module docstring) of samples ``y`` [u] (NaN = missing) at ``dt`` [s], in the band
    the fitted ``components`` give; None when none enters N or the band holds fewer than :data:`MIN_BINS` bins."""
    inside = [c for c in components if enters_n(c, dt)]
    others = [c for c in components if not enters_n(c, dt) and not isinstance(c, RR)]
    x = interpolate_missing(np.asarray(y, dtype=float))
    segment = min(WELCH_SEGMENT, x.size // 8)
    if not inside or segment < 2 * MIN_BINS:
        return None
    f, one_sided = signal.welch(x, fs=1.0 / dt, nperseg=segment, detrend="linear")
    f, s = f[1:], one_sided[1:] / 2.0  # two-sided, the convention of N; 0 Hz left out
    n0 = sum(c.zero_frequency_density(dt) ** 2 for c in inside)
    white = np.sum([c.psd(f, dt) for c in inside], axis=0)
    other = np.sum([c.psd(f, dt) for c in others], axis=0) if others else np.zeros_like(f)
    gain = white / n0
    band = (white >= WHITE_SHARE * (white + other)) & (gain >= WHITE_SHARE) & (gain <= 1.0 / WHITE_SHARE)
    bins = int(band.sum())
    if bins < MIN_BINS:
        return None
    level = float(np.mean((s[band] - other[band]) / gain[band]))
    if not level > 0.0:
        return None
    segments = 1 + (x.size - segment) // (segment // 2)
    sd_log_n = 0.5 * math.sqrt(WELCH_VARIANCE_FACTOR * ADJACENT_BIN_FACTOR / (segments * bins))
    n = math.sqrt(level)
    return PassbandLevel(n, (n * math.exp(-Z95 * sd_log_n), n * math.exp(Z95 * sd_log_n)),
                         (float(f[band][0]), float(f[band][-1])), bins)
