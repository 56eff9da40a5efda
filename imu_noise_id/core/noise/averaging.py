"""The sensor's averaging filter (MA), white noise through a two-tap moving average (docs/noise.md): y_k = e_k +
e_{k−1}, var(e) = σ², density N [u/√Hz], N² = 4σ²dt; S(f) = N² cos²(πf·dt), AV(m·dt) = (4m − 3)σ²/m²; block as QN's,
Q = diag(σ², 0) (first element free), H = [1, 1]."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from . import units
from .base import Component, StateBlock, as_freq, as_tau


@dataclass(frozen=True)
class MA(Component):
    """A two-tap moving average of white noise of passband density N [u/√Hz]."""

    noise_density: float

    name: ClassVar[str] = "MA"
    parameter_names: ClassVar[tuple[str, ...]] = ("noise_density",)
    scale_name: ClassVar[str | None] = "noise_density"
    parameter_units: ClassVar[dict[str, str]] = {"noise_density": "u/sqrt(Hz)"}

    def __post_init__(self) -> None:
        units._check_positive("noise_density", self.noise_density)

    def sigma2(self, dt: float) -> float:
        """Variance σ² [u²] of each of the two averaged samples, N²/(4 dt)."""
        return self.noise_density**2 / (4.0 * dt)

    def simulate(self, n: int, dt: float, rng: np.random.Generator) -> np.ndarray:
        e = rng.standard_normal(n + 1) * math.sqrt(self.sigma2(dt))
        return e[1:] + e[:-1]

    def block(self, dt: float) -> StateBlock:
        return StateBlock(
            phi=np.array([[0.0, 0.0], [1.0, 0.0]]), q=np.diag([self.sigma2(dt), 0.0]), h=np.array([1.0, 1.0]),
            u=np.zeros(2), phi_free=np.zeros((2, 2), bool), q_free=np.array([[True, False], [False, False]]),
            u_free=np.zeros(2, bool),
        )

    def allan_variance(self, tau: np.ndarray | float, dt: float) -> np.ndarray:
        m = as_tau(tau) / dt
        return (4.0 * m - 3.0) * self.sigma2(dt) / (m * m)

    def psd(self, f: np.ndarray | float, dt: float) -> np.ndarray:
        return self.noise_density**2 * np.cos(math.pi * as_freq(f) * dt) ** 2

    def sum_covariance(self, lag: np.ndarray, dt: float) -> np.ndarray:
        """K(u) = −½ S(|u|), S(m) = (4m − 2)σ² for m ≥ 1, 0 at 0."""
        u = np.abs(np.asarray(lag, dtype=float))
        return np.where(u > 0, -(2.0 * u - 1.0) * self.sigma2(dt), 0.0)

    def zero_frequency_density(self, dt: float) -> float:
        """N exactly: dt·(R(0) + 2R(dt)) = 4σ²dt = N²."""
        return self.noise_density

    def per_sample(self, dt: float) -> dict[str, float]:
        return {"sigma2_ma": self.sigma2(dt), "sigma2_per_sample": 2.0 * self.sigma2(dt)}

    @classmethod
    def from_per_sample(cls, dt: float, **values: float) -> MA:
        return cls(math.sqrt(4.0 * dt * units._check_positive("sigma2_ma", values["sigma2_ma"])))

    @classmethod
    def from_block(cls, phi: np.ndarray, q: np.ndarray, dt: float) -> MA:
        return cls.from_per_sample(dt, sigma2_ma=max(float(q[0, 0]), 0.0))
