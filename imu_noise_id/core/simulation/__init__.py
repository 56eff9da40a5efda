"""Simulated sensors with known errors: static IMU, ground robot, AV bands of a model."""
