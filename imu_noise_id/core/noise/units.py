"""Exact conversions between continuous-time noise parameters and per-sample values (the one place they live).

==========================  ================  ===========================================================
quantity (u: rad/s, m/s²)   unit              per-sample value at period ``dt`` [s]
==========================  ================  ===========================================================
white noise density N       u/√Hz             σ²_WN = N²/dt                            (Kalibr: σ_d = N/√dt)
random-walk density K       u/s/√Hz           σ²_RW = K²·dt                            (Kalibr: σ_bd = K·√dt)
Gauss–Markov τ, σ           s, u              φ = exp(−dt/τ), σ²_drive = σ²(1 − φ²)
rate ramp ω                 u/s               ω·dt
quantisation Q              u·s               σ²_QN = Q²/dt² (variance of ε_k/dt)
==========================  ================  ===========================================================

Paper 000 (Stebler et al. 2011) uses the Euler form 1 − βΔt, 2βσ²_GM (:func:`gm_to_paper000`)."""

from __future__ import annotations

import math

import numpy as np

#: No IMU parameter comes near this; beyond it squares and products overflow.
ABSURD = 1e100


def _check_positive(name: str, value: float, allow_zero: bool = True) -> float:
    value = float(value)
    if not math.isfinite(value) or value < 0 or (value == 0 and not allow_zero) or value > ABSURD:
        need = "≥ 0" if allow_zero else "> 0"
        raise ValueError(f"{name} must be a finite number {need} and at most {ABSURD:g}, got {value!r}")
    return value


def white_noise_sigma2(noise_density: float, dt: float) -> float:
    """Per-sample variance σ²_WN = N²/dt of white noise with density N [u/√Hz]."""
    return _check_positive("noise_density", noise_density) ** 2 / _check_positive("dt", dt, False)


def white_noise_density(sigma2_per_sample: float, dt: float) -> float:
    """Density N = √(σ²_WN · dt) [u/√Hz] from the per-sample variance."""
    return math.sqrt(_check_positive("sigma2_per_sample", sigma2_per_sample) * _check_positive("dt", dt, False))


def random_walk_sigma2(random_walk: float, dt: float) -> float:
    """Per-sample increment variance σ²_RW = K²·dt of a random walk with density K [u/s/√Hz]."""
    return _check_positive("random_walk", random_walk) ** 2 * _check_positive("dt", dt, False)


def random_walk_density(sigma2_per_sample: float, dt: float) -> float:
    """Density K = √(σ²_RW / dt) [u/s/√Hz] from the per-sample increment variance."""
    return math.sqrt(_check_positive("sigma2_per_sample", sigma2_per_sample) / _check_positive("dt", dt, False))


def random_walk_at_allan_variance(allan_variance: float | np.ndarray, tau: float | np.ndarray) -> float | np.ndarray:
    """K = √(3·AV/τ) [u/s/√Hz]: the random walk whose AV K²τ/3 (IEEE Std 952 table C.2) is ``allan_variance`` at
    ``tau``."""
    k = np.sqrt(3.0 * np.asarray(allan_variance, dtype=float) / np.asarray(tau, dtype=float))
    return float(k) if k.ndim == 0 else k


def gm_phi(tau: float, dt: float) -> float:
    """Exact transition φ = exp(−dt/τ) of a GM with correlation time τ [s]."""
    return math.exp(-_check_positive("dt", dt, False) / _check_positive("tau", tau, False))


def gm_drive_sigma2(tau: float, sigma: float, dt: float) -> float:
    """Exact per-sample driving variance σ²(1 − φ²) of a GM process with stationary std σ."""
    phi = gm_phi(tau, dt)
    return _check_positive("sigma", sigma) ** 2 * (1.0 - phi * phi)


def gm_from_discrete(phi: float, drive_sigma2: float, dt: float) -> tuple[float, float]:
    """(φ, q) → (τ [s], σ [u]), inverting the exact discretisation; ValueError unless φ ∈ (0, 1)."""
    if not 0.0 < phi < 1.0:
        raise ValueError(f"Gauss-Markov transition phi must lie in (0, 1), got {phi!r}")
    tau = -_check_positive("dt", dt, False) / math.log(phi)
    sigma = math.sqrt(_check_positive("drive_sigma2", drive_sigma2) / (1.0 - phi * phi))
    return tau, sigma


def gm_to_paper000(tau: float, sigma: float) -> dict[str, float]:
    """Paper 000's notation for a GM process: β = 1/τ [1/s], σ²_GM = σ² [u²] (stationary variance)."""
    return {"beta": 1.0 / _check_positive("tau", tau, False), "sigma2_gm": _check_positive("sigma", sigma) ** 2}


def gm_from_paper000(beta: float, sigma2_gm: float) -> tuple[float, float]:
    """(β, σ²_GM) of paper 000 → (τ [s], σ [u])."""
    return 1.0 / _check_positive("beta", beta, False), math.sqrt(_check_positive("sigma2_gm", sigma2_gm))


def ramp_per_sample(slope: float, dt: float) -> float:
    """Per-sample increment ω·dt of a rate ramp with slope ω [u/s]."""
    if not math.isfinite(slope):
        raise ValueError(f"slope must be finite, got {slope!r}")
    return float(slope) * _check_positive("dt", dt, False)


def quantization_sigma2(q: float, dt: float) -> float:
    """Variance Q²/dt² of one quantisation term ε_k/dt (:class:`~.components.QN`)."""
    return _check_positive("Q", q) ** 2 / _check_positive("dt", dt, False) ** 2


def covariance_from_density(noise_density: float | np.ndarray, rate_hz: float) -> float | np.ndarray:
    """sensor_msgs/Imu covariance diagonal N²·f [u²] for a white-noise density N sampled at f [Hz]."""
    return np.square(noise_density) * _check_positive("rate_hz", rate_hz, False)


def step_noise_std(density: float, step_s: float, weight: float = 1.0) -> float:
    """σ = density / √(weight · step) [u]: the white-rate std a discrete filter needs for ``density`` at ``step_s``
    [s]; ``weight`` 1: one input sample per step (PX4 EKF2, VINS' bias blocks), ½: the mid-point rule (VINS)."""
    return _check_positive("density", density) / math.sqrt(
        _check_positive("weight", weight, False) * _check_positive("step_s", step_s, False))


def density_from_step_noise_std(sigma: float, step_s: float, weight: float = 1.0) -> float:
    """Inverse of :func:`step_noise_std`: density = σ·√(weight · step)."""
    return _check_positive("sigma", sigma) * math.sqrt(
        _check_positive("weight", weight, False) * _check_positive("step_s", step_s, False))
