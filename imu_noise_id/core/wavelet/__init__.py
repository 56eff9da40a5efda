"""Haar wavelet variance, the moments the GMWM (:mod:`imu_noise_id.core.estimation.gmwm.fit`) fits: classical,
robust, and its model-based covariance."""

from .covariance import theoretical_wv, wv_covariance
from .robust import BiweightScale, hampel_clean
from .variance import WaveletVariance, dyadic_m, wavelet_variance

__all__ = ["BiweightScale", "WaveletVariance", "dyadic_m", "hampel_clean", "theoretical_wv", "wavelet_variance",
           "wv_covariance"]
