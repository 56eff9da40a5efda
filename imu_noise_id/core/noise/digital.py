"""The sensor's digital low-pass (DLPF): white noise (density N [u/√Hz], σ² = N²/dt) through an order-n Butterworth
designed by the bilinear transform at the sampling rate, H = ``scipy.signal.butter(n, f_c, fs=1/dt)``
(docs/noise.md): S(f) = N²|H(e^{i2πf dt})|², zero at Nyquist; f_c [Hz] the −3 dB cutoff < 1/(2 dt); n structure.
Block: the direct form II in difference coordinates (:func:`_difference_realisation`), Q = diag(b₀²σ², 0 …) (first
element free); AV(m·dt) = (4 S(m) − S(2m))/(2m²), R(j) = σ² Σ_k h_k h_{k+j}."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy import optimize, signal

from . import units
from .base import Component, StateBlock, as_freq, as_tau

#: Orders a DLPF may have.
ORDERS = (1, 2, 3, 4)
#: Relative level [–] below which the impulse response counts as decayed ...
DECAY = 1e-14
#: ... and for at most this many samples.
MAX_RESPONSE = 1 << 20


@functools.lru_cache(maxsize=256)
def _design(order: int, cutoff_per_sample: float) -> tuple[np.ndarray, np.ndarray]:
    """(b, a) of the Butterworth low-pass of ``order`` at f_c·dt (< ½), as ``scipy.signal.butter`` designs it (n zeros
    at z = −1, the bilinear transform's poles, unit gain at DC), from :func:`_poles`: b = b₀(1 + z⁻¹)ⁿ,
    a = Π(1 − z_k z⁻¹) (a third of butter's time, which a climb over f_c spends at every step)."""
    _, _, b0 = _poles(order, cutoff_per_sample)
    b = b0 * np.array([math.comb(order, k) for k in range(order + 1)], dtype=float)
    return b, np.real(np.poly(_z_poles(order, cutoff_per_sample)))


@functools.lru_cache(maxsize=64)
def _covariance(order: int, cutoff_per_sample: float) -> np.ndarray:
    """R(j)/σ² for j = 0 … J−1, J the impulse response's length."""
    b, a = _design(order, cutoff_per_sample)
    radius = max(float(np.max(np.abs(_z_poles(order, cutoff_per_sample)))), 1e-3)
    length = int(min(MAX_RESPONSE, max(64, math.ceil(math.log(DECAY) / math.log(radius)) + 4 * order)))
    impulse = np.zeros(length)
    impulse[0] = 1.0
    h = signal.lfilter(b, a, impulse)
    size = 1 << math.ceil(math.log2(2 * length))
    spectrum = np.fft.rfft(h, size)
    return np.fft.irfft(spectrum * np.conj(spectrum), size)[:length]


@functools.lru_cache(maxsize=256)
def _poles(order: int, cutoff_per_sample: float) -> tuple[float, np.ndarray, float]:
    """(λ, ŝ, b₀) of the order-n Butterworth at f_c·dt: λ = 2 tan(π f_c dt), the poles z_k = 1 + λŝ_k with
    ŝ_k = p_k/(1 − λp_k/2) (p_k the normalised prototype's), b₀ the numerator's gain, b(z⁻¹) = b₀(1 + z⁻¹)ⁿ."""
    lam = 2.0 * math.tan(math.pi * cutoff_per_sample)
    prototype = -np.exp(1j * math.pi * np.arange(-order + 1, order, 2) / (2 * order))
    s_hat = prototype / (1.0 - 0.5 * lam * prototype)
    return lam, s_hat, float(np.real(np.prod(-s_hat))) * (0.5 * lam) ** order


def _z_poles(order: int, cutoff_per_sample: float) -> np.ndarray:
    """The Butterworth's poles z_k = 1 + λŝ_k in the z-plane (:func:`_poles`)."""
    lam, s_hat, _ = _poles(order, cutoff_per_sample)
    return 1.0 + lam * s_hat


@functools.lru_cache(maxsize=256)
def _difference_realisation(order: int, cutoff_per_sample: float) -> tuple[np.ndarray, np.ndarray, float]:
    """(Φ, h, b₀) of the order-n Butterworth at f_c·dt on the direct form II's signal w (w_t = b₀e_t − Σ a_i w_{t−i},
    y_t = Σ_i C(n, i) w_{t−i}) in difference coordinates: x⁰_t = Δⁿw_t, x^{k}_t = Δ^{k−1}w_{t−1} (k = 1 … n),
    Δ = 1 − z⁻¹.

    The Butterworth's poles z_k = 1 + λŝ_k (λ = 2 tan(π f_c dt), the prewarped analog cutoff per sample;
    ŝ_k = p_k/(1 − λp_k/2) with p_k the normalised prototype's poles, all of order one) give
    a(z⁻¹) = Π(1 − z_k z⁻¹) = Π(z_k Δ − λŝ_k) = Σ_j α_j Δʲ with α_j of order λ^{n−j}, exactly, where the
    coefficients a_i are O(1) and cancel to O(λⁿ). With D_j(t) = D_n(t) + Σ_{i=j}^{n−1} D_i(t−1):

        x⁰_{t+1} = b₀e_{t+1} − Σ_i β_i (x⁰_t + Σ_{m≥i} x^{m+1}_t),  β_i = Σ_{j≤i} α_j,
        x^{k}_{t+1} = x⁰_t + Σ_{i≥k−1} x^{i+1}_t,   y_t = Σ_j C(n, j) 2^{n−j} (−1)ʲ D_j(t).

    Only state 0's row depends on f_c and only state 0 is driven (the EM's M-step and the score assume both), H is
    parameter-free (as for the direct form II, which it is a fixed similarity of), and the states are differences of
    the order of λʲ, not lagged values agreeing to 1 − O(λ²) that make the Riccati equation singular in double
    precision at low f_c dt (the δ-operator's argument, Middleton & Goodwin 1990)."""
    n = order
    lam, s_hat, b0 = _poles(order, cutoff_per_sample)
    alpha = np.ones(1, dtype=complex)  # ascending powers of Δ
    for s_k in s_hat:
        alpha = np.convolve(alpha, [-lam * s_k, 1.0 + lam * s_k])
    beta = np.cumsum(np.real(alpha))[:n]
    phi = np.zeros((n + 1, n + 1))
    phi[0, 0] = -float(np.sum(beta))
    phi[0, 1:] = -np.cumsum(beta)
    for k in range(1, n + 1):
        phi[k, 0] = 1.0
        phi[k, k:] = 1.0
    weights = np.array([math.comb(n, j) * 2.0 ** (n - j) * (-1.0) ** j for j in range(n + 1)])
    h = np.concatenate([[float(np.sum(weights))], np.cumsum(weights[:n])])
    return phi, h, b0


@dataclass(frozen=True)
class DLPF(Component):
    """White noise of passband density N [u/√Hz] through an n-th order digital Butterworth low-pass at f_c [Hz]."""

    noise_density: float
    cutoff: float
    order: int = 2

    name: ClassVar[str] = "DLPF"
    parameter_names: ClassVar[tuple[str, ...]] = ("noise_density", "cutoff")
    scale_name: ClassVar[str | None] = "noise_density"
    parameter_units: ClassVar[dict[str, str]] = {"noise_density": "u/sqrt(Hz)", "cutoff": "Hz"}
    fixed_names: ClassVar[tuple[str, ...]] = ("order",)

    def __post_init__(self) -> None:
        units._check_positive("noise_density", self.noise_density)
        units._check_positive("cutoff", self.cutoff, allow_zero=False)
        if int(self.order) != self.order or int(self.order) not in ORDERS:
            raise ValueError(f"DLPF order must be one of {ORDERS}, got {self.order!r}")
        object.__setattr__(self, "order", int(self.order))

    def _per_sample(self, dt: float) -> float:
        x = self.cutoff * dt
        if not 0.0 < x < 0.5:
            raise ValueError(f"DLPF cutoff {self.cutoff:g} Hz must lie below the Nyquist frequency {0.5 / dt:g} Hz")
        return x

    def coefficients(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """(b, a) of the filter at period ``dt`` [s]."""
        return _design(self.order, self._per_sample(dt))

    def sigma2(self, dt: float) -> float:
        """Variance σ² = N²/dt [u²] of the white noise driving the filter."""
        return self.noise_density**2 / dt

    def simulate(self, n: int, dt: float, rng: np.random.Generator) -> np.ndarray:
        b, a = self.coefficients(dt)
        warm = _covariance(self.order, self._per_sample(dt)).size
        w = rng.standard_normal(n + warm) * math.sqrt(self.sigma2(dt))
        return signal.lfilter(b, a, w)[warm:]

    def block(self, dt: float) -> StateBlock:
        """The block of :func:`_difference_realisation` (Q's first element b₀²σ², free)."""
        phi, h, b0 = _difference_realisation(self.order, self._per_sample(dt))
        p = self.order + 1
        q = np.zeros((p, p))
        q[0, 0] = b0**2 * self.sigma2(dt)
        q_free = np.zeros((p, p), bool)
        q_free[0, 0] = True
        return StateBlock(phi=phi.copy(), q=q, h=h.copy(), u=np.zeros(p), phi_free=np.zeros((p, p), bool),
                          q_free=q_free, u_free=np.zeros(p, bool))

    def sample_spectrum(self, omega: np.ndarray, dt: float) -> np.ndarray:
        """Spectral density per sample σ²|H(e^{iω})|² [u²] at ω [rad/sample], from the factored form
        |b₀|²|1 + e^{−iω}|²ⁿ / Π_k |z_k Δ − λŝ_k|² with Δ = 1 − e^{−iω} = 2 sin²(ω/2) + i sin ω and
        |1 + e^{−iω}|² = 4 cos²(ω/2) (:func:`_poles`): no cancellation of the coefficients a_i near ω = 0 (where
        |a| = O(λⁿ)) nor of the numerator near Nyquist, O(n) per frequency."""
        lam, s_hat, b0 = _poles(self.order, self._per_sample(dt))
        omega = np.asarray(omega, dtype=float)
        half = np.sin(0.5 * omega)
        delta = 2.0 * half * half + 1j * np.sin(omega)
        den = np.ones_like(omega)
        for s_k in s_hat:
            den = den * np.abs((1.0 + lam * s_k) * delta - lam * s_k) ** 2
        num = (2.0 * np.cos(0.5 * omega)) ** (2 * self.order)
        return self.sigma2(dt) * b0 * b0 * num / den

    def autocovariance(self, lags: np.ndarray, dt: float) -> np.ndarray:
        """R(j) [u²] at integer lags (0 beyond the response's length)."""
        r = _covariance(self.order, self._per_sample(dt)) * self.sigma2(dt)
        j = np.abs(np.asarray(lags, dtype=int))
        return np.where(j < r.size, r[np.minimum(j, r.size - 1)], 0.0)

    def block_sum_variance(self, m: np.ndarray, dt: float) -> np.ndarray:
        """S(m) = Var(y_1 + … + y_m) [u²] at integer m ≥ 0."""
        r = _covariance(self.order, self._per_sample(dt)) * self.sigma2(dt)
        j = np.arange(r.size)
        # S(m) = m R0 + 2 Σ_{j=1}^{m−1} (m − j) R(j) = m (R0 + 2 C1(m)) − 2 C2(m), C1, C2 the prefix sums of R, jR
        c1 = np.concatenate([[0.0], np.cumsum(r[1:])])
        c2 = np.concatenate([[0.0], np.cumsum(j[1:] * r[1:])])
        m = np.rint(np.asarray(m, dtype=float)).astype(np.int64)
        k = np.clip(m - 1, 0, r.size - 1)
        return np.where(m > 0, m * (r[0] + 2.0 * c1[k]) - 2.0 * c2[k], 0.0)

    def allan_variance(self, tau: np.ndarray | float, dt: float) -> np.ndarray:
        m = np.rint(as_tau(tau) / dt)
        return (4.0 * self.block_sum_variance(m, dt) - self.block_sum_variance(2.0 * m, dt)) / (2.0 * m * m)

    def sum_covariance(self, lag: np.ndarray, dt: float) -> np.ndarray:
        """K(u) = −½ S(|u|)."""
        return -0.5 * self.block_sum_variance(np.abs(np.asarray(lag, dtype=float)), dt)

    def psd(self, f: np.ndarray | float, dt: float) -> np.ndarray:
        """N²|H(e^{i2πf dt})|² = dt × :meth:`sample_spectrum`."""
        return dt * self.sample_spectrum(2.0 * math.pi * as_freq(f) * dt, dt)

    def zero_frequency_density(self, dt: float) -> float:
        """N exactly (H(1) = 1)."""
        return self.noise_density

    def memory(self, dt: float) -> tuple[float, float, float]:
        poles = _z_poles(self.order, self._per_sample(dt))
        decay = -dt / np.log(np.maximum(np.abs(poles), 1e-300))
        angle = np.abs(np.angle(poles))
        period = float(2.0 * math.pi * dt / np.max(angle)) if np.max(angle) > 0 else math.inf
        return float(np.max(decay)), float(np.min(decay)), period

    def per_sample(self, dt: float) -> dict[str, float]:
        r0 = float(_covariance(self.order, self._per_sample(dt))[0]) * self.sigma2(dt)
        return {"sigma2_dlpf": self.sigma2(dt), "sigma2_per_sample": r0}

    @classmethod
    def from_per_sample(cls, dt: float, **values: float) -> DLPF:
        return cls(math.sqrt(units._check_positive("sigma2_dlpf", values["sigma2_dlpf"]) * dt), values["cutoff"],
                   int(values.get("order", 2)))

    @classmethod
    def from_block(cls, phi: np.ndarray, q: np.ndarray, dt: float) -> DLPF:
        """The DLPF of the block of :meth:`block`: f_c from Φ₀₀ (monotone in f_c), N = √(Q₀₀·dt)/b₀."""
        order = phi.shape[0] - 1
        target = float(phi[0, 0])

        def gap(x: float) -> float:
            return float(_difference_realisation(order, x)[0][0, 0]) - target

        lo, hi = 1e-9, 0.5 - 1e-9
        x = optimize.brentq(gap, lo, hi, xtol=1e-15) if gap(lo) * gap(hi) < 0 else (lo if abs(gap(lo)) < abs(
            gap(hi)) else hi)
        b0 = _difference_realisation(order, x)[2]
        return cls(math.sqrt(max(float(q[0, 0]), 0.0) * dt) / b0, x / dt, order)


@dataclass(frozen=True)
class SensorFilter:
    """The sensor's configured low-pass: −3 dB ``cutoff`` [Hz] and, if known, ``order`` (a fit tries only it, else
    :data:`ORDERS`)."""

    cutoff: float
    order: int | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.cutoff) and self.cutoff > 0):
            raise ValueError(f"the sensor filter's cutoff must be a finite number of Hz > 0, got {self.cutoff!r}")
        if self.order is not None and self.order not in ORDERS:
            raise ValueError(f"the sensor filter's order must be one of {ORDERS}, got {self.order!r}")

    def __str__(self) -> str:
        """The command line's form, ``HZ[:ORDER]``."""
        return f"{self.cutoff:g}" + ("" if self.order is None else f":{self.order}")

    @property
    def orders(self) -> tuple[int, ...]:
        """The orders a fit tries."""
        return ORDERS if self.order is None else (self.order,)

    def check_rate(self, dt: float) -> None:
        """ValueError unless the cutoff is below the Nyquist frequency 1/(2 dt), ``dt`` [s]."""
        if not self.cutoff * dt < 0.5:
            raise ValueError(f"the sensor filter's cutoff {self.cutoff:g} Hz is not below the record's Nyquist "
                             f"frequency {0.5 / dt:g} Hz")
