"""Covariance matching Kalman filter (paper 004): the paper's turntable filter and its robot generalisation."""
