"""Covariance matching Kalman filter (paper 004) per axis and on a robot (paper's filter: test/reference_cmkf.py)."""
