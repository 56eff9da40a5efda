"""The sensor's first-order low-pass (LPF) and a narrow-band stochastic oscillation (OSC); docs/noise.md. LPF: x' =
−ω_c x + ω_c w, ω_c = 2πf_c, PSD(w) = N²: S(f) = N²/(1 + (f/f_c)²), the GM of τ = 1/ω_c, σ² = πN²f_c. OSC: x'' +
2ζω₀x' + ω₀²x = w, PSD q = 4ζω₀³σ²; f₀, B = 2ζf₀ [Hz], σ [u]; R(u) = Re(c e^{su}), c = σ²(1 − ia/ω_d), s = −a + iω_d
(a = ζω₀, ω_d = ω₀√(1 − ζ²)); state [x, x'/ω₀], H = [1, 0], exact discretisation (Van Loan)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy import signal

from . import units
from .base import Component, StateBlock, as_freq, as_tau
from .sampled import block_sum_variance, sampled_allan_variance, zero_frequency_psd

#: The sensor's own filter has a memory below this many sampling periods ...
FILTER_MAX_TAU_SAMPLES = 5
#: ... or below this many seconds [s], whatever the rate.
FILTER_MAX_TAU_S = 0.05


def filter_memory_limit(dt: float) -> float:
    """Longest memory [s] of the sensor's own filter: max(:data:`FILTER_MAX_TAU_SAMPLES`·dt,
    :data:`FILTER_MAX_TAU_S`)."""
    return max(FILTER_MAX_TAU_SAMPLES * dt, FILTER_MAX_TAU_S)


#: Largest damping ratio of an OSC (ζ < 1: a resonance, not two real poles).
MAX_DAMPING = 0.95
#: Damping ratio of a second-order Butterworth low-pass, 1/√2.
BUTTERWORTH_DAMPING = 1.0 / math.sqrt(2.0)


def _positive(name: str, value: float) -> float:
    return units._check_positive(name, value, allow_zero=False)


@dataclass(frozen=True)
class LPF(Component):
    """White noise of passband density N [u/√Hz] through a first-order low-pass of cutoff f_c [Hz]."""

    noise_density: float
    cutoff: float

    name: ClassVar[str] = "LPF"
    parameter_names: ClassVar[tuple[str, ...]] = ("noise_density", "cutoff")
    scale_name: ClassVar[str | None] = "noise_density"
    parameter_units: ClassVar[dict[str, str]] = {"noise_density": "u/sqrt(Hz)", "cutoff": "Hz"}

    def __post_init__(self) -> None:
        _positive("noise_density", self.noise_density)
        _positive("cutoff", self.cutoff)

    @property
    def tau(self) -> float:
        """Correlation time 1/(2π f_c) [s]."""
        return 1.0 / (2.0 * math.pi * self.cutoff)

    @property
    def sigma(self) -> float:
        """Stationary (per-sample) std √(πN²f_c) [u]."""
        return self.noise_density * math.sqrt(math.pi * self.cutoff)

    def _gm(self):
        from .components import GM

        return GM(tau=self.tau, sigma=self.sigma)

    def simulate(self, n: int, dt: float, rng: np.random.Generator) -> np.ndarray:
        return self._gm().simulate(n, dt, rng)

    def block(self, dt: float) -> StateBlock:
        blk = self._gm().block(dt)
        return StateBlock(phi=blk.phi, q=blk.q, h=blk.h, u=blk.u, phi_free=np.zeros((1, 1), bool),
                          q_free=np.zeros((1, 1), bool), u_free=blk.u_free)

    def allan_variance(self, tau: np.ndarray | float, dt: float) -> np.ndarray:
        return self._gm().allan_variance(tau, dt)

    def sum_covariance(self, lag: np.ndarray, dt: float) -> np.ndarray:
        return self._gm().sum_covariance(lag, dt)

    def memory(self, dt: float) -> tuple[float, float, float]:
        return self.tau, self.tau, math.inf

    def exponential_terms(self) -> tuple[np.ndarray, np.ndarray]:
        """Its GM's (:meth:`from_gm`)."""
        return self._gm().exponential_terms()

    def exponential_term_derivatives(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """c = πN²f_c and s = −2πf_c are both ∝ f_c: ∂/∂ln f_c of each is itself."""
        c, s = self.exponential_terms()
        return {"cutoff": (c, s)}

    def psd(self, f: np.ndarray | float, dt: float) -> np.ndarray:
        return self.noise_density**2 / (1.0 + (as_freq(f) / self.cutoff) ** 2)

    def zero_frequency_density(self, dt: float) -> float:
        """N·√((x/2)·coth(x/2)), x = 2πf_c dt: the sampled AR(1)'s √(σ² dt (1 + φ)/(1 − φ))."""
        return math.sqrt(zero_frequency_psd(self.sigma**2, -1.0 / self.tau, dt))

    def per_sample(self, dt: float) -> dict[str, float]:
        phi = units.gm_phi(self.tau, dt)
        return {"phi": phi, "sigma2": self.sigma**2, "sigma2_drive": self.sigma**2 * (1.0 - phi * phi)}

    @classmethod
    def from_per_sample(cls, dt: float, **values: float) -> LPF:
        tau, sigma = units.gm_from_discrete(values["phi"], values["sigma2_drive"], dt)
        return cls.from_gm(tau, sigma)

    @classmethod
    def from_gm(cls, tau: float, sigma: float) -> LPF:
        """The LPF that is the GM (τ [s], σ [u])."""
        cutoff = 1.0 / (2.0 * math.pi * tau)
        return cls(sigma / math.sqrt(math.pi * cutoff), cutoff)

    @classmethod
    def from_block(cls, phi: np.ndarray, q: np.ndarray, dt: float) -> LPF:
        from .components import GM

        gm = GM.from_block(phi, q, dt)
        return cls.from_gm(gm.tau, gm.sigma)


@dataclass(frozen=True)
class OSC(Component):
    """Narrow-band stochastic oscillation: f₀ [Hz], half-power bandwidth B [Hz], stationary σ [u] (module docstring)."""

    frequency: float
    bandwidth: float
    sigma: float

    name: ClassVar[str] = "OSC"
    parameter_names: ClassVar[tuple[str, ...]] = ("frequency", "bandwidth", "sigma")
    scale_name: ClassVar[str | None] = "sigma"
    parameter_units: ClassVar[dict[str, str]] = {"frequency": "Hz", "bandwidth": "Hz", "sigma": "u"}

    def __post_init__(self) -> None:
        _positive("frequency", self.frequency)
        _positive("bandwidth", self.bandwidth)
        units._check_positive("sigma", self.sigma)
        if self.damping > MAX_DAMPING:
            raise ValueError(f"OSC bandwidth {self.bandwidth:g} Hz is too wide for a resonance at {self.frequency:g} "
                             f"Hz (damping {self.damping:.3g} > {MAX_DAMPING}): use a GM instead")

    @property
    def omega0(self) -> float:
        """Natural angular frequency ω₀ = 2π f₀ [rad/s]."""
        return 2.0 * math.pi * self.frequency

    @property
    def damping(self) -> float:
        """Damping ratio ζ = B / (2 f₀)."""
        return self.bandwidth / (2.0 * self.frequency)

    def _poles(self) -> tuple[float, float]:
        """(a, ω_d): decay rate ζω₀ [1/s], damped angular frequency ω₀√(1 − ζ²) [rad/s]."""
        z = self.damping
        return z * self.omega0, self.omega0 * math.sqrt(1.0 - z * z)

    def _autocovariance(self) -> tuple[complex, complex]:
        a, wd = self._poles()
        return self.sigma**2 * complex(1.0, -a / wd), complex(-a, wd)

    def stationary_covariance(self) -> np.ndarray:
        """P∞ of the state [x, x'/ω₀]: σ² I."""
        return np.eye(2) * self.sigma**2

    def transition(self, dt: float) -> np.ndarray:
        """Φ of the state [x, x'/ω₀]: exp(A dt), A = [[0, 1], [−ω₀², −2ζω₀]], in closed form, scaled."""
        a, wd = self._poles()
        e = math.exp(-a * dt)
        c, s = math.cos(wd * dt), math.sin(wd * dt)
        w0 = self.omega0
        return e * np.array([[c + a / wd * s, w0 / wd * s], [-w0 / wd * s, c - a / wd * s]])

    def process_noise(self, dt: float) -> np.ndarray:
        """Q = ∫₀^dt e^{Aτ} B q Bᵀ e^{Aᵀτ} dτ of the scaled state, in closed form: the discretisation is exact and the
        state stationary with P∞ = σ² I, so Q = P∞ − Φ P∞ Φᵀ = σ² (I − Φ Φᵀ). With a, ω_d of :meth:`_poles`,
        r = a/ω_d, w = ω₀/ω_d, θ = ω_d dt and E = e^{−2a dt} (1 − E by expm1, no cancellation for a dt ≪ 1):
        Q₁₁ = σ² [1 − E − 2E r sinθ (cosθ + r sinθ)], Q₂₂ = σ² [1 − E + 2E r sinθ (cosθ − r sinθ)],
        Q₁₂ = 2σ² E r w sin²θ."""
        a, wd = self._poles()
        r, w, theta = a / wd, self.omega0 / wd, wd * dt
        c, s = math.cos(theta), math.sin(theta)
        e, one_minus_e = math.exp(-2.0 * a * dt), -math.expm1(-2.0 * a * dt)
        var = self.sigma**2
        q11 = one_minus_e - 2.0 * e * r * s * (c + r * s)
        q22 = one_minus_e + 2.0 * e * r * s * (c - r * s)
        q12 = 2.0 * e * r * w * s * s
        return var * np.array([[q11, q12], [q12, q22]])

    def block(self, dt: float) -> StateBlock:
        if self.frequency >= 0.5 / _positive("dt", dt):
            raise ValueError(f"OSC frequency {self.frequency:g} Hz is at or above the Nyquist frequency "
                             f"{0.5 / dt:g} Hz of the sampling period {dt:g} s")
        phi = self.transition(dt)
        q = self.process_noise(dt)
        return StateBlock(phi=phi, q=q, h=np.array([1.0, 0.0]), u=np.zeros(2), phi_free=np.zeros((2, 2), bool),
                          q_free=np.zeros((2, 2), bool), u_free=np.zeros(2, bool))

    def simulate(self, n: int, dt: float, rng: np.random.Generator) -> np.ndarray:
        blk = self.block(dt)
        phi, h = blk.phi, blk.h
        # x_{k+1} = Φ x_k + L z_k: each noise input through its transfer function, plus the free response of x_0.
        lq = np.linalg.cholesky(blk.q + 1e-300 * np.eye(2))
        den = np.array([1.0, -np.trace(phi), np.linalg.det(phi)])
        out = np.zeros(n)
        for j in range(2):
            num, _ = signal.ss2tf(phi, lq[:, j:j + 1], h[None, :], np.zeros((1, 1)))
            out += signal.lfilter(num[0], den, rng.standard_normal(n))
        x0 = np.linalg.cholesky(self.stationary_covariance()) @ rng.standard_normal(2)
        free = np.empty(n)
        x = x0.copy()
        y_prev = [h @ x, h @ (phi @ x)]
        free[0] = y_prev[0]
        if n > 1:
            free[1] = y_prev[1]
        # The free response obeys the characteristic recursion y_k = tr(Φ) y_{k−1} − det(Φ) y_{k−2}.
        if n > 2:
            free[2:] = signal.lfilter([1.0], den, np.zeros(n - 2),
                                      zi=signal.lfiltic([1.0], den, y=[free[1], free[0]]))[0]
        return out + free

    def allan_variance(self, tau: np.ndarray | float, dt: float) -> np.ndarray:
        """AV of the sampled process, R(u) = Re(c e^{su}) (:mod:`.sampled`)."""
        return sampled_allan_variance(*self._autocovariance(), as_tau(tau), dt)

    def sum_covariance(self, lag: np.ndarray, dt: float) -> np.ndarray:
        """K(u) = −½ Var(y_1 + … + y_|u|) from R(u) = Re(c e^{su})."""
        u = np.abs(np.asarray(lag, dtype=float))
        return -0.5 * block_sum_variance(*self._autocovariance(), u, dt)

    def memory(self, dt: float) -> tuple[float, float, float]:
        a, wd = self._poles()
        return 1.0 / a, 1.0 / a, 2.0 * math.pi / wd

    def exponential_terms(self) -> tuple[np.ndarray, np.ndarray]:
        """R(u) = Re(c e^{su}) (:meth:`_autocovariance`)."""
        c, s = self._autocovariance()
        return np.array([c]), np.array([s])

    def exponential_term_derivatives(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """With a = πB and ω_d² = ω₀² − a² (:meth:`_poles`), c = σ²(1 − i a/ω_d), s = −a + iω_d:
        ∂ω_d/∂ln f₀ = ω₀²/ω_d, ∂ω_d/∂ln B = −a²/ω_d, ∂a/∂ln B = a, so ∂s/∂ln f₀ = iω₀²/ω_d, ∂c/∂ln f₀ =
        iσ² a ω₀²/ω_d³, ∂s/∂ln B = −a − i a²/ω_d, ∂c/∂ln B = −iσ² (a/ω_d + a³/ω_d³); at :data:`MAX_DAMPING` too,
        as the limit from inside the domain."""
        a, wd = self._poles()
        w0 = self.omega0
        var = self.sigma**2
        return {"frequency": (np.array([1j * var * a * w0 * w0 / wd**3]), np.array([1j * w0 * w0 / wd])),
                "bandwidth": (np.array([-1j * var * (a / wd + a**3 / wd**3)]), np.array([complex(-a, -a * a / wd)]))}

    def psd(self, f: np.ndarray | float, dt: float) -> np.ndarray:
        w = 2.0 * math.pi * as_freq(f)
        w0, z = self.omega0, self.damping
        q = 4.0 * z * w0**3 * self.sigma**2
        return q / ((w0 * w0 - w * w) ** 2 + (2.0 * z * w0 * w) ** 2)

    def zero_frequency_density(self, dt: float) -> float:
        """√(dt·Σ_j R(j)) of the sampled oscillation; continuous limit S(0) = σ²B/(πf₀²)."""
        return math.sqrt(max(zero_frequency_psd(*self._autocovariance(), dt), 0.0))

    def per_sample(self, dt: float) -> dict[str, float]:
        a, wd = self._poles()
        return {"damping": self.damping, "rho": math.exp(-a * dt), "theta": wd * dt, "sigma2": self.sigma**2}

    @classmethod
    def low_pass(cls, noise_density: float, corner: float, damping: float = BUTTERWORTH_DAMPING) -> OSC:
        """White noise of density N [u/√Hz] through a second-order low-pass of corner f₀ [Hz] and damping ζ (default
        1/√2, Butterworth): B = 2ζf₀, σ = N f₀ √(π/B), S(0) = N²."""
        bandwidth = 2.0 * damping * corner
        return cls(corner, bandwidth, noise_density * corner * math.sqrt(math.pi / bandwidth))

    @classmethod
    def from_per_sample(cls, dt: float, **values: float) -> OSC:
        """From the pole ρ e^{±iθ} per sample (ρ = e^{−a dt}, θ = ω_d dt) and σ²."""
        return cls.from_poles(-math.log(values["rho"]) / dt, values["theta"] / dt, math.sqrt(values["sigma2"]))

    @classmethod
    def from_poles(cls, a: float, wd: float, sigma: float) -> OSC:
        """From a = ζω₀ [1/s], ω_d [rad/s] and σ [u]."""
        w0 = math.hypot(a, wd)
        z = a / w0
        f0 = w0 / (2.0 * math.pi)
        return cls(f0, 2.0 * z * f0, sigma)

    @classmethod
    def from_block(cls, phi: np.ndarray, q: np.ndarray, dt: float) -> OSC:
        lam = np.linalg.eigvals(phi)[0]
        rho, theta = abs(lam), abs(np.angle(lam))
        p = _stationary(phi, q)
        return cls.from_per_sample(dt, rho=min(rho, 1.0 - 1e-12), theta=theta, sigma2=max(float(p[0, 0]), 0.0))


def _stationary(phi: np.ndarray, q: np.ndarray) -> np.ndarray:
    """P with P = Φ P Φᵀ + Q (2×2, by the Kronecker form)."""
    p = np.linalg.solve(np.eye(4) - np.kron(phi, phi), q.ravel()).reshape(2, 2)
    return 0.5 * (p + p.T)
