"""Comparisons of Kalman smoother outputs shared by ``test_kalman.py`` and ``test_harmonic.py`` (helpers, not tests)."""

from __future__ import annotations

import dataclasses

import numpy as np

from imu_noise_id.core import kalman


def assert_state_sums_close(got: kalman.StateSums, want: kalman.StateSums, y: np.ndarray, z: np.ndarray, *,
                            rtol: float, atol_rel: float) -> None:
    """Every sum of the smoothed means in ``got`` against ``want`` over the data y (N,) and regressors z (N, k), the
    absolute tolerance ``atol_rel`` times the sum's scale: the largest magnitude of a p × p sum in ``want``; for the
    first and last means the means' root mean square x_rms = √(max diag Σ x xᵀ / N) (a state near zero at one end has
    no scale of its own); for Σ x, Σ y x and Σ z x the sum of the magnitudes they cancel from, N·x_rms times the
    root mean square of 1, y or z."""
    n = y.size
    x_rms = float(np.sqrt(np.max(np.diag(want.gram), initial=0.0) / n))
    rms = np.sqrt(np.mean(z * z, axis=0)) if z.size else np.zeros(0)
    scale = {"first": x_rms, "last": x_rms, "total": n * x_rms, "y_cross": n * x_rms * float(np.sqrt(np.mean(y * y))),
             "z_cross": n * x_rms * float(np.max(rms, initial=0.0))}
    for f in dataclasses.fields(kalman.StateSums):
        a, b = np.asarray(getattr(want, f.name)), np.asarray(getattr(got, f.name))
        largest = float(np.max(np.abs(a), initial=0.0))
        np.testing.assert_allclose(b, a, rtol=rtol, atol=atol_rel * scale.get(f.name, largest), err_msg=f.name)
