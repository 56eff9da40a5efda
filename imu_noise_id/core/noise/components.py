"""Stochastic error components WN, QN, RW, GM, RR (LPF, DLPF, OSC, BI, MA: sibling modules), frozen dataclasses of
continuous-time parameters with simulation, state block (paper 000 eqs. 4–5, 7–9), AV [u²] of the sampled process,
two-sided PSD [u²/Hz] (IEEE Std 952: AV(τ) = 4∫₀^∞ S(f) sin⁴(πfτ)/(πfτ)² df) and per-sample values (paper 000)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy.signal import lfilter

from . import units
from .averaging import MA
from .base import Component, StateBlock, as_freq, as_tau
from .digital import DLPF
from .flicker import BI
from .resonant import LPF, OSC
from .sampled import block_sum_variance, sampled_allan_variance

#: Smallest and largest Gauss–Markov transition :meth:`GM.from_block` accepts (the EM keeps φ inside too).
PHI_RANGE: tuple[float, float] = (1e-12, 1.0 - 1e-12)


@dataclass(frozen=True)
class WN(Component):
    """Gaussian white noise (angle / velocity random walk), density N [u/√Hz]: σ²_WN = N²/dt, AV = N²/τ, S(f) = N²."""

    noise_density: float

    name: ClassVar[str] = "WN"
    parameter_names: ClassVar[tuple[str, ...]] = ("noise_density",)
    scale_name: ClassVar[str | None] = "noise_density"
    parameter_units: ClassVar[dict[str, str]] = {"noise_density": "u/sqrt(Hz)"}

    def __post_init__(self) -> None:
        units.white_noise_sigma2(self.noise_density, 1.0)

    def simulate(self, n: int, dt: float, rng: np.random.Generator) -> np.ndarray:
        return rng.standard_normal(n) * math.sqrt(units.white_noise_sigma2(self.noise_density, dt))

    def block(self, dt: float) -> StateBlock:
        return StateBlock(
            phi=np.zeros((0, 0)), q=np.zeros((0, 0)), h=np.zeros(0),
            r=units.white_noise_sigma2(self.noise_density, dt), r_free=True,
        )

    def allan_variance(self, tau: np.ndarray | float, dt: float) -> np.ndarray:
        return self.noise_density**2 / as_tau(tau)

    def psd(self, f: np.ndarray | float, dt: float) -> np.ndarray:
        return np.full_like(as_freq(f), self.noise_density**2)

    def sum_covariance(self, lag: np.ndarray, dt: float) -> np.ndarray:
        """K(u) = −σ²|u|/2 with σ² = N²/dt (:meth:`Component.sum_covariance`)."""
        return -0.5 * units.white_noise_sigma2(self.noise_density, dt) * np.abs(np.asarray(lag, dtype=float))

    def zero_frequency_density(self, dt: float) -> float:
        return self.noise_density

    def per_sample(self, dt: float) -> dict[str, float]:
        return {"sigma2_wn": units.white_noise_sigma2(self.noise_density, dt)}

    @classmethod
    def from_per_sample(cls, dt: float, **values: float) -> WN:
        return cls(units.white_noise_density(values["sigma2_wn"], dt))


@dataclass(frozen=True)
class QN(Component):
    """Quantisation noise Q [u·s] of an integrating sensor (IEEE Std 952): e_k = (ε_k − ε_{k−1})/dt, var(ε) = Q²
    (uniform on ±√3·Q when simulated); AV(τ) = 3Q²/τ², S(f) = (4Q²/dt)·sin²(πf·dt). Block: states [ε_k/dt,
    ε_{k−1}/dt], Φ = [[0, 0], [1, 0]], Q = diag(Q²/dt², 0) (first element free), H = [1, −1]."""

    Q: float

    name: ClassVar[str] = "QN"
    parameter_names: ClassVar[tuple[str, ...]] = ("Q",)
    scale_name: ClassVar[str | None] = "Q"
    parameter_units: ClassVar[dict[str, str]] = {"Q": "u*s"}

    def __post_init__(self) -> None:
        units.quantization_sigma2(self.Q, 1.0)

    def simulate(self, n: int, dt: float, rng: np.random.Generator) -> np.ndarray:
        eps = rng.uniform(-math.sqrt(3.0) * self.Q, math.sqrt(3.0) * self.Q, n + 1)
        return np.diff(eps) / dt

    def block(self, dt: float) -> StateBlock:
        return StateBlock(
            phi=np.array([[0.0, 0.0], [1.0, 0.0]]),
            q=np.diag([units.quantization_sigma2(self.Q, dt), 0.0]),
            h=np.array([1.0, -1.0]),
            u=np.zeros(2),
            phi_free=np.zeros((2, 2), bool),
            q_free=np.array([[True, False], [False, False]]),
            u_free=np.zeros(2, bool),
        )

    def allan_variance(self, tau: np.ndarray | float, dt: float) -> np.ndarray:
        return 3.0 * self.Q**2 / as_tau(tau) ** 2

    def psd(self, f: np.ndarray | float, dt: float) -> np.ndarray:
        return 4.0 * self.Q**2 * np.sin(math.pi * as_freq(f) * dt) ** 2 / dt

    def sum_covariance(self, lag: np.ndarray, dt: float) -> np.ndarray:
        """K(u) = −Q²/dt² for u ≠ 0, 0 at u = 0."""
        return np.where(np.asarray(lag) != 0, -units.quantization_sigma2(self.Q, dt), 0.0)

    def per_sample(self, dt: float) -> dict[str, float]:
        return {"sigma2_qn": units.quantization_sigma2(self.Q, dt)}

    @classmethod
    def from_per_sample(cls, dt: float, **values: float) -> QN:
        return cls(math.sqrt(units._check_positive("sigma2_qn", values["sigma2_qn"])) * dt)

    @classmethod
    def from_block(cls, phi: np.ndarray, q: np.ndarray, dt: float) -> QN:
        return cls.from_per_sample(dt, sigma2_qn=max(float(q[0, 0]), 0.0))


@dataclass(frozen=True)
class RW(Component):
    """Random walk, density K [u/s/√Hz]: var(w) = K²·dt, sampled AV K²τ/3 + K²dt²/(6τ), S(f) = K²/(2πf)²."""

    random_walk: float

    name: ClassVar[str] = "RW"
    parameter_names: ClassVar[tuple[str, ...]] = ("random_walk",)
    scale_name: ClassVar[str | None] = "random_walk"
    parameter_units: ClassVar[dict[str, str]] = {"random_walk": "u/s/sqrt(Hz)"}

    def __post_init__(self) -> None:
        units.random_walk_sigma2(self.random_walk, 1.0)

    def simulate(self, n: int, dt: float, rng: np.random.Generator) -> np.ndarray:
        return np.cumsum(rng.standard_normal(n) * math.sqrt(units.random_walk_sigma2(self.random_walk, dt)))

    def block(self, dt: float) -> StateBlock:
        return StateBlock(
            phi=np.ones((1, 1)), q=np.array([[units.random_walk_sigma2(self.random_walk, dt)]]),
            h=np.ones(1), u=np.zeros(1),
            phi_free=np.zeros((1, 1), bool), q_free=np.ones((1, 1), bool), u_free=np.zeros(1, bool),
        )

    def allan_variance(self, tau: np.ndarray | float, dt: float) -> np.ndarray:
        tau = as_tau(tau)
        return self.random_walk**2 * (tau / 3.0 + dt**2 / (6.0 * tau))

    def psd(self, f: np.ndarray | float, dt: float) -> np.ndarray:
        return self.random_walk**2 / (2.0 * math.pi * as_freq(f)) ** 2

    def sum_covariance(self, lag: np.ndarray, dt: float) -> np.ndarray:
        """K(u) = q(|u|³ − |u|)/12, q = K²·dt (doubly summed white noise)."""
        u = np.abs(np.asarray(lag, dtype=float))
        return units.random_walk_sigma2(self.random_walk, dt) * (u**3 - u) / 12.0

    def per_sample(self, dt: float) -> dict[str, float]:
        return {"sigma2_rw": units.random_walk_sigma2(self.random_walk, dt)}

    @classmethod
    def from_per_sample(cls, dt: float, **values: float) -> RW:
        return cls(units.random_walk_density(values["sigma2_rw"], dt))

    @classmethod
    def from_block(cls, phi: np.ndarray, q: np.ndarray, dt: float) -> RW:
        return cls.from_per_sample(dt, sigma2_rw=max(float(q[0, 0]), 0.0))


@dataclass(frozen=True)
class GM(Component):
    """First-order Gauss–Markov, correlation time τ [s], stationary std σ [u]: φ = exp(−dt/τ), var(w) = σ²(1 − φ²)
    (paper 002 eq. 22; paper 000: φ ≈ 1 − β·dt, β = 1/τ); S(f) = 2σ²τ/(1 + (2πfτ)²)."""

    tau: float
    sigma: float

    name: ClassVar[str] = "GM"
    parameter_names: ClassVar[tuple[str, ...]] = ("tau", "sigma")
    scale_name: ClassVar[str | None] = "sigma"
    parameter_units: ClassVar[dict[str, str]] = {"tau": "s", "sigma": "u"}

    def __post_init__(self) -> None:
        units.gm_phi(self.tau, 1.0)
        units.gm_drive_sigma2(self.tau, self.sigma, 1.0)

    def simulate(self, n: int, dt: float, rng: np.random.Generator) -> np.ndarray:
        phi = units.gm_phi(self.tau, dt)
        drive = rng.standard_normal(n) * math.sqrt(units.gm_drive_sigma2(self.tau, self.sigma, dt))
        x0 = rng.standard_normal() * self.sigma
        out, _ = lfilter([1.0], [1.0, -phi], drive, zi=[phi * x0])
        return out

    def block(self, dt: float) -> StateBlock:
        return StateBlock(
            phi=np.array([[units.gm_phi(self.tau, dt)]]),
            q=np.array([[units.gm_drive_sigma2(self.tau, self.sigma, dt)]]),
            h=np.ones(1), u=np.zeros(1),
            phi_free=np.ones((1, 1), bool), q_free=np.ones((1, 1), bool), u_free=np.zeros(1, bool),
        )

    def allan_variance(self, tau: np.ndarray | float, dt: float) -> np.ndarray:
        """AV of the sampled process, R(j) = σ² e^{−j·dt/τ} (:mod:`.sampled`)."""
        return sampled_allan_variance(self.sigma**2, -1.0 / self.tau, as_tau(tau), dt)

    def psd(self, f: np.ndarray | float, dt: float) -> np.ndarray:
        f = as_freq(f)
        return 2.0 * self.sigma**2 * self.tau / (1.0 + (2.0 * math.pi * f * self.tau) ** 2)

    def sum_covariance(self, lag: np.ndarray, dt: float) -> np.ndarray:
        """K(u) = −½ Var(y_1 + … + y_|u|), R(j) = σ² e^{−j·dt/τ}."""
        return -0.5 * block_sum_variance(self.sigma**2, -1.0 / self.tau, np.abs(np.asarray(lag, dtype=float)), dt)

    def memory(self, dt: float) -> tuple[float, float, float]:
        return self.tau, self.tau, math.inf

    def exponential_terms(self) -> tuple[np.ndarray, np.ndarray]:
        """R(u) = σ² e^{−u/τ}."""
        return np.array([self.sigma**2], dtype=complex), np.array([-1.0 / self.tau], dtype=complex)

    def exponential_term_derivatives(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """c = σ² does not move with τ; ∂s/∂ln τ = 1/τ."""
        return {"tau": (np.zeros(1, dtype=complex), np.array([1.0 / self.tau], dtype=complex))}

    def per_sample(self, dt: float) -> dict[str, float]:
        return {
            **units.gm_to_paper000(self.tau, self.sigma),
            "phi": units.gm_phi(self.tau, dt),
            "sigma2_drive": units.gm_drive_sigma2(self.tau, self.sigma, dt),
        }

    @classmethod
    def from_per_sample(cls, dt: float, **values: float) -> GM:
        if "phi" in values:
            return cls(*units.gm_from_discrete(values["phi"], values["sigma2_drive"], dt))
        return cls(*units.gm_from_paper000(values["beta"], values["sigma2_gm"]))

    @classmethod
    def from_block(cls, phi: np.ndarray, q: np.ndarray, dt: float) -> GM:
        # EM updates that leave (0, 1) are clipped (a documented beyond-the-paper safeguard).
        return cls.from_per_sample(dt, phi=float(np.clip(phi[0, 0], *PHI_RANGE)), sigma2_drive=max(float(q[0, 0]), 0.0))


@dataclass(frozen=True)
class RR(Component):
    """Rate ramp of slope ω [u/s]: y_k = ω·k·dt, AV(τ) = ω²τ²/2, S(f) = ω²/(2πf)³; block an integrator (Φ = 1, Q = 0,
    H = 1) driven by u = ω·dt (paper 000 sec. 4.1–4.3)."""

    slope: float

    name: ClassVar[str] = "RR"
    parameter_names: ClassVar[tuple[str, ...]] = ("slope",)
    parameter_units: ClassVar[dict[str, str]] = {"slope": "u/s"}

    def __post_init__(self) -> None:
        units.ramp_per_sample(self.slope, 1.0)

    def simulate(self, n: int, dt: float, rng: np.random.Generator) -> np.ndarray:
        return self.slope * dt * np.arange(n, dtype=float)

    def block(self, dt: float) -> StateBlock:
        return StateBlock(
            phi=np.ones((1, 1)), q=np.zeros((1, 1)), h=np.ones(1),
            u=np.array([units.ramp_per_sample(self.slope, dt)]),
            phi_free=np.zeros((1, 1), bool), q_free=np.zeros((1, 1), bool), u_free=np.ones(1, bool),
        )

    def allan_variance(self, tau: np.ndarray | float, dt: float) -> np.ndarray:
        return 0.5 * self.slope**2 * as_tau(tau) ** 2

    def psd(self, f: np.ndarray | float, dt: float) -> np.ndarray:
        return self.slope**2 / (2.0 * math.pi * as_freq(f)) ** 3

    def sum_covariance(self, lag: np.ndarray, dt: float) -> np.ndarray:
        """Zero: the ramp is deterministic."""
        return np.zeros(np.shape(lag))

    def per_sample(self, dt: float) -> dict[str, float]:
        return {"omega": float(self.slope), "omega_dt": units.ramp_per_sample(self.slope, dt)}

    @classmethod
    def from_per_sample(cls, dt: float, **values: float) -> RR:
        if "omega_dt" in values:
            return cls(values["omega_dt"] / dt)
        return cls(values["omega"])


#: Registry of component types by spec name.
COMPONENT_TYPES: dict[str, type[Component]] = {c.name: c for c in (WN, QN, RW, GM, RR, LPF, DLPF, OSC, BI, MA)}


def total_allan_variance(components: list[Component], tau: np.ndarray, dt: float) -> np.ndarray:
    """AV [u²] of a sum of independent components (AVs add)."""
    tau = as_tau(tau)
    return np.sum([c.allan_variance(tau, dt) for c in components], axis=0) if components else np.zeros_like(tau)


def simulate_sum(components: list[Component], n: int, dt: float, rng: np.random.Generator) -> np.ndarray:
    """n samples of the sum of independent components."""
    if n < 1:
        raise ValueError(f"number of samples must be >= 1, got {n}")
    units._check_positive("dt", dt, allow_zero=False)
    out = np.zeros(n)
    for c in components:
        out += c.simulate(n, dt, rng)
    return out
