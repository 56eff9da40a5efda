"""Stochastic error components of an inertial sensor, their units and model specs (docs/noise.md)."""
