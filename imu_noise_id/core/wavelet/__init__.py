"""Haar wavelet variance, the moments the GMWM fits (:mod:`imu_noise_id.core.estimation.gmwm.fit`): the WV at dyadic
scales (:mod:`.variance`), its robust M-estimator (:mod:`.robust`) and the model-based covariance
(:mod:`.covariance`)."""

from .covariance import theoretical_wv, wv_covariance
from .robust import BiweightScale, hampel_clean
from .variance import WaveletVariance, dyadic_m, wavelet_variance

__all__ = ["BiweightScale", "WaveletVariance", "dyadic_m", "hampel_clean", "theoretical_wv", "wavelet_variance",
           "wv_covariance"]
