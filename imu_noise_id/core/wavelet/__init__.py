"""Haar wavelet variance: the moments the GMWM fits (:mod:`imu_noise_id.core.estimation.gmwm`).

* :mod:`.variance` — the WV of one axis at dyadic scales (half the maximal-overlap Allan variance), classical or
  robust, with per-scale χ² intervals;
* :mod:`.robust` — the bounded-influence M-estimator of a level's variance and the spike flags before it;
* :mod:`.covariance` — the theoretical WV of a component model and the exact Gaussian covariance of the estimates.
"""

from .covariance import theoretical_wv, wv_covariance
from .robust import BiweightScale, hampel_clean
from .variance import WaveletVariance, dyadic_m, wavelet_variance

__all__ = ["BiweightScale", "WaveletVariance", "dyadic_m", "hampel_clean", "theoretical_wv", "wavelet_variance",
           "wv_covariance"]
