"""Physical and statistical constants the package uses in more than one place, each written once.

Nothing is imported here (the bag reader reads :data:`STANDARD_GRAVITY` without pulling in numpy or scipy).
"""

#: Standard gravity g_n [m/s²]: the conventional value fixed by the 3rd CGPM (1901), exact by definition (NIST SP
#: 330, ISO 80000-3). A static level accelerometer reads about this on its vertical axis (local gravity spans
#: 9.78–9.83 m/s²); the simulations, the robot CMKF and the Kalibr/OpenVINS ``g_norm`` export use it.
STANDARD_GRAVITY = 9.80665

#: The 95 % two-sided confidence level: the default level of the Allan-family intervals (``DEFAULT_CONFIDENCE``
#: in :mod:`.allan`) and the fixed level of the loop's AV band, the wavelet variance's intervals and the
#: random-walk bound. Its normal and χ²₁ quantiles are ``Z95`` and ``CHI2_95`` in :mod:`.estimation.quantiles`.
CONFIDENCE_95 = 0.95
