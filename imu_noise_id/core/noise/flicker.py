"""Bias instability (flicker noise) as a ladder of first-order GMs (docs/noise.md): IEEE Std 952 annex C S(f) =
B²/(2πf), AV plateau (2 ln 2/π)·B²; τ_i = τ_min·ρ^i (i < M), equal variances σ² = B² ln ρ/π (Keshner 1982, Proc. IEEE
70(3)) give Σ_i 2σ²τ_i/(1 + (2πfτ_i)²) ≈ B²/(2πf) for 1/(2πτ_max) ≪ f ≪ 1/(2πτ_min), ripple ≈ 4·e^{−π²/ln ρ}. The
band is structure (:func:`band_for_record`); only B is estimated."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy.signal import lfilter

from . import units
from .base import Component, StateBlock, as_freq, as_tau
from .sampled import real_poles_sum_variance, sampled_allan_variance

#: Correlation times per decade of the ladder.
PER_DECADE = 2
#: Allan-variance plateau of flicker noise over B²: 2 ln 2 / π (IEEE Std 952, annex C).
PLATEAU = 2.0 * math.log(2.0) / math.pi
#: Shortest correlation time of a fitted ladder [samples].
TAU_MIN_SAMPLES = 10.0


def band_for_record(n: int, dt: float) -> tuple[float, float]:
    """The band [τ_min, τ_max] [s] for ``n`` samples at ``dt`` [s]: :data:`TAU_MIN_SAMPLES` samples to the record."""
    tau_min = TAU_MIN_SAMPLES * dt
    return tau_min, max(n * dt, 10.0 * tau_min)


def ladder_taus(tau_min: float, tau_max: float) -> np.ndarray:
    """Correlation times [s] of the ladder: evenly spaced in log τ, :data:`PER_DECADE` a decade, ends included."""
    decades = math.log10(tau_max / tau_min)
    count = max(2, math.ceil(decades * PER_DECADE - 1e-9) + 1)
    return np.exp(np.linspace(math.log(tau_min), math.log(tau_max), count))


@dataclass(frozen=True)
class BI(Component):
    """Flicker rate noise of bias instability B [u] over [τ_min, τ_max] [s]: PSD ≈ B²/(2πf), AV plateau ≈ (2 ln
    2/π)·B²."""

    bias_instability: float
    tau_min: float = 1.0
    tau_max: float = 1000.0

    name: ClassVar[str] = "BI"
    parameter_names: ClassVar[tuple[str, ...]] = ("bias_instability",)
    scale_name: ClassVar[str | None] = "bias_instability"
    parameter_units: ClassVar[dict[str, str]] = {"bias_instability": "u", "tau_min": "s", "tau_max": "s"}
    #: Structure values a spec may give after the parameters (the band), not estimated.
    fixed_names: ClassVar[tuple[str, ...]] = ("tau_min", "tau_max")

    def __post_init__(self) -> None:
        units._check_positive("bias_instability", self.bias_instability)
        units._check_positive("tau_min", self.tau_min, allow_zero=False)
        units._check_positive("tau_max", self.tau_max, allow_zero=False)
        if not self.tau_max > self.tau_min:
            raise ValueError(f"BI band: tau_max ({self.tau_max:g} s) must exceed tau_min ({self.tau_min:g} s)")

    @property
    def taus(self) -> np.ndarray:
        """The ladder's correlation times [s]."""
        return ladder_taus(self.tau_min, self.tau_max)

    @property
    def sigma2_each(self) -> float:
        """Stationary variance B² ln ρ/π [u²] of every GM of the ladder."""
        taus = self.taus
        return self.bias_instability**2 * math.log(taus[1] / taus[0]) / math.pi

    def _phi_drive(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        phi = np.exp(-dt / self.taus)
        return phi, self.sigma2_each * -np.expm1(-2.0 * dt / self.taus)

    def simulate(self, n: int, dt: float, rng: np.random.Generator) -> np.ndarray:
        phi, drive = self._phi_drive(dt)
        out = np.zeros(n)
        s = math.sqrt(self.sigma2_each)
        for p, q in zip(phi, drive, strict=True):
            x0 = rng.standard_normal() * s
            out += lfilter([1.0], [1.0, -p], rng.standard_normal(n) * math.sqrt(q), zi=[p * x0])[0]
        return out

    def block(self, dt: float) -> StateBlock:
        phi, drive = self._phi_drive(dt)
        m = phi.size
        return StateBlock(phi=np.diag(phi), q=np.diag(drive), h=np.ones(m), u=np.zeros(m),
                          phi_free=np.zeros((m, m), bool), q_free=np.zeros((m, m), bool), u_free=np.zeros(m, bool))

    def allan_variance(self, tau: np.ndarray | float, dt: float) -> np.ndarray:
        taus = self.taus
        return sampled_allan_variance(np.full(taus.size, self.sigma2_each), -1.0 / taus, as_tau(tau), dt)

    def sum_covariance(self, lag: np.ndarray, dt: float) -> np.ndarray:
        """K(u) of the ladder: the sum over its GMs (:mod:`.sampled`)."""
        u = np.abs(np.asarray(lag, dtype=float))
        return -0.5 * real_poles_sum_variance(self.sigma2_each, -1.0 / self.taus, u, dt)

    def memory(self, dt: float) -> tuple[float, float, float]:
        taus = self.taus
        return float(taus[-1]), float(taus[0]), math.inf

    def exponential_terms(self) -> tuple[np.ndarray, np.ndarray]:
        """R(u) = Σ_j σ²_each e^{−u/τ_j} over the ladder's GMs."""
        taus = self.taus
        return np.full(taus.size, self.sigma2_each, dtype=complex), (-1.0 / taus).astype(complex)

    def psd(self, f: np.ndarray | float, dt: float) -> np.ndarray:
        w = 2.0 * math.pi * as_freq(f)[..., None]
        taus = self.taus
        return np.sum(2.0 * self.sigma2_each * taus / (1.0 + (w * taus) ** 2), axis=-1)

    def per_sample(self, dt: float) -> dict[str, float]:
        phi = np.exp(-dt / self.taus)
        return {"n_states": float(phi.size), "sigma2_each": self.sigma2_each, "phi_min": float(phi.min()),
                "phi_max": float(phi.max())}

    @classmethod
    def from_per_sample(cls, dt: float, **values: float) -> BI:
        """From ``sigma2_each`` and the band's ``phi_min``, ``phi_max`` (:meth:`per_sample`)."""
        tau_min, tau_max = -dt / math.log(values["phi_min"]), -dt / math.log(values["phi_max"])
        rho = ladder_taus(tau_min, tau_max)
        return cls(math.sqrt(values["sigma2_each"] * math.pi / math.log(rho[1] / rho[0])), tau_min, tau_max)

    @classmethod
    def from_block(cls, phi: np.ndarray, q: np.ndarray, dt: float) -> BI:
        p = np.diag(phi)
        sigma2 = float(np.mean(np.diag(q) / -np.expm1(2.0 * np.log(p))))
        return cls.from_per_sample(dt, sigma2_each=max(sigma2, 0.0), phi_min=float(p.min()), phi_max=float(p.max()))
