"""Physical and statistical constants the package uses in more than one place, each written once; no imports."""

#: Standard gravity g_n [m/s²] (3rd CGPM 1901, exact by definition; NIST SP 330).
STANDARD_GRAVITY = 9.80665

#: The 95 % two-sided confidence level (Allan-family intervals, the loop's AV band, the WV intervals, the RW bound).
CONFIDENCE_95 = 0.95
