"""Watching an IMU against its own reference: sequential noise-level tests, step and line searches (:mod:`.compare`)."""
