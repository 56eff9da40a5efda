"""What the online identification returns: plain dataclasses (the node turns them into messages)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class CorrectedImu:
    """One bias-corrected IMU sample; variances N²·f per axis (None while unknown); ``source`` as the caller gave it."""

    t: float
    gyro: tuple[float, float, float]
    accel: tuple[float, float, float]
    gyro_variance: tuple[float, float, float] | None
    accel_variance: tuple[float, float, float] | None
    source: Any = None


@dataclass
class Estimates:
    """Current estimates, SI units; per-axis arrays in :data:`~imu_noise_id.core.axes.AXES` order.

    Attributes
    ----------
    t : last IMU stamp [s]; cmkf_status : the CMKF's status; imu_rate : nominal [Hz]; stationary : now
    gyro_bias, gyro_bias_std, accel_bias, accel_bias_std : (3,) [rad/s], [m/s²] (NaN before the first odometry update)
    noise_density, noise_density_rstd, noise_samples : (6,) stationary white-noise density [u/√Hz] (NaN before
        ``noise.min_samples``), its relative std, the differences used
    psd, psd_se, psd_upper : (6,) Ŝ_g [rad²/s], Ŝ_v [m²/s³] where identified, standard error, 95 % upper end where not
    covariance, covariance_source : (6,) N²·f [u²] of ``~/imu_corrected`` and its source (``stationary``, ``cmkf``, …)
    bank_theta : parameter → (6,) θ̂ of each axis's most probable hypothesis (NaN where absent)
    """

    t: float
    cmkf_status: str
    gyro_bias: np.ndarray
    gyro_bias_std: np.ndarray
    accel_bias: np.ndarray
    accel_bias_std: np.ndarray
    noise_density: np.ndarray
    noise_density_rstd: float
    noise_samples: int
    psd: np.ndarray
    psd_se: np.ndarray
    psd_upper: np.ndarray
    covariance: np.ndarray
    covariance_source: str
    imu_rate: float
    stationary: bool
    bank_theta: dict[str, np.ndarray]

    #: Column labels of :meth:`noise_table` before the bank's parameter names.
    NOISE_FIELDS: tuple[str, ...] = (
        "noise_density", "noise_density_rstd", "covariance", "bias", "bias_std", "cmkf_psd", "cmkf_psd_se",
        "cmkf_noise_density", "cmkf_noise_density_upper", "stationary_samples",
    )

    def noise_table(self) -> tuple[tuple[str, ...], np.ndarray]:
        """Labels (:attr:`NOISE_FIELDS`, then ``bank_<parameter>``) and the (6, columns) table of ``~/noise``."""
        fields = self.NOISE_FIELDS + tuple(f"bank_{name}" for name in self.bank_theta)
        table = np.full((6, len(fields)), math.nan)
        table[:, 0] = self.noise_density
        table[:, 1] = self.noise_density_rstd
        table[:, 2] = self.covariance
        table[:3, 3] = self.gyro_bias
        table[3:, 3] = self.accel_bias
        table[:3, 4] = self.gyro_bias_std
        table[3:, 4] = self.accel_bias_std
        table[:, 5] = self.psd
        table[:, 6] = self.psd_se
        table[:, 7] = np.sqrt(self.psd)
        table[:, 8] = np.sqrt(self.psd_upper)
        table[:, 9] = self.noise_samples
        for j, values in enumerate(self.bank_theta.values()):
            table[:, len(self.NOISE_FIELDS) + j] = values
        return fields, table


def _nan6() -> np.ndarray:
    return np.full(6, np.nan)


@dataclass
class HypothesesReport:
    """Posterior probabilities per axis (rows) and hypothesis (``names`` columns; NaN without a bank); ``decision``
    index (−1: none), ``updates``, ``notes`` (indistinguishable pairs), ``decision_probability``, ``decision_time`` [s],
    ``gamma``."""

    names: tuple[str, ...]
    probabilities: np.ndarray
    decision: np.ndarray
    updates: np.ndarray
    notes: tuple[str, ...] = ("",) * 6
    decision_probability: np.ndarray = field(default_factory=_nan6)
    decision_time: np.ndarray = field(default_factory=_nan6)
    gamma: np.ndarray = field(default_factory=_nan6)

    def table(self) -> tuple[tuple[str, ...], np.ndarray]:
        """Column labels (hypothesis names, ``decision``, ``bank_updates``, ``decision_probability``,
        ``decision_time_s``, ``gamma``) and the (6, columns) table."""
        return (*self.names, "decision", "bank_updates", "decision_probability", "decision_time_s", "gamma"), \
            np.column_stack([self.probabilities, self.decision, self.updates, self.decision_probability,
                             self.decision_time, self.gamma])


#: Columns of the ``~/hypotheses`` table that are not hypotheses.
HYPOTHESES_EXTRA_COLUMNS = ("decision", "bank_updates", "decision_probability", "decision_time_s", "gamma")


def decision_text(name: str | None, *, raw: float, held: float, since: float, gamma: float) -> str:
    """The decision as a person reads it beside the raw probabilities (name, time, and why it differs from the raw
    probability: hysteresis below ``gamma`` or a merged GM); ``"—"`` while undecided."""
    if name is None:
        return "—"
    when = f"{since:.3g} s" if np.isfinite(since) else "an earlier update"
    if np.isfinite(held) and np.isfinite(gamma) and held < gamma:
        return f"{name} (held: P {held:.3f} < gamma {gamma:g} since it was decided at {when})"
    if np.isfinite(held) and abs(held - raw) > 5e-4:
        return f"{name} (P {held:.3f} with the GM hypothesis it cannot tell apart merged, since {when})"
    return f"{name} (since {when})"
