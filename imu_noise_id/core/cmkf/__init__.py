"""Covariance matching Kalman filter (paper 004): the paper's filter per axis and its robot generalisation
(the paper's two-axis turntable filter written out literally is a test reference: ``test/reference_cmkf.py``)."""
