"""Watching an IMU against its own reference: sequential noise-level tests and the step and line searches under
the reference's model (:mod:`.noise_level`, :mod:`.compare`)."""
