"""The component protocol: what every stochastic error component provides (docs/noise.md)."""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field, fields
from typing import ClassVar

import numpy as np


@dataclass(frozen=True)
class StateBlock:
    """One component's part of the state-space model, paper 000 eqs. 4–5: x_{t+1} = Φ x_t + w_t + u, w_t ~ N(0, Q);
    y_t = H x_t + v_t, v_t ~ N(0, R). ``phi``, ``q`` (p, p); ``h``, ``u`` (p,) (u: input per step); ``r`` its share
    of R (WN only); ``*_free``: elements the estimator may change (paper 000 eq. 7)."""

    phi: np.ndarray
    q: np.ndarray
    h: np.ndarray
    r: float = 0.0
    u: np.ndarray = field(default_factory=lambda: np.zeros(0))
    phi_free: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), bool))
    q_free: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), bool))
    u_free: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    r_free: bool = False

    @property
    def n_states(self) -> int:
        return int(self.phi.shape[0])


def _finite_positive(x: np.ndarray) -> bool:
    return x.size == 0 or bool(x.min() > 0.0 and math.isfinite(x.max()))


def as_tau(tau: np.ndarray | float) -> np.ndarray:
    tau = np.asarray(tau, dtype=float)
    if not _finite_positive(tau):
        raise ValueError("averaging times tau must be finite and > 0")
    return tau


def as_freq(f: np.ndarray | float) -> np.ndarray:
    f = np.asarray(f, dtype=float)
    if not _finite_positive(f):
        raise ValueError("frequencies f must be finite and > 0")
    return f


class Component(ABC):
    """Base class of the stochastic error components."""

    name: ClassVar[str]
    #: Names of the continuous-time parameters, in the order positional spec values are read.
    parameter_names: ClassVar[tuple[str, ...]]
    #: Units of the continuous-time parameters, ``u`` standing for the signal's unit.
    parameter_units: ClassVar[dict[str, str]]
    #: Structure values a spec may give after the parameters, never estimated (e.g. a flicker ladder's band).
    fixed_names: ClassVar[tuple[str, ...]] = ()
    #: The parameter whose square every second moment of the component (covariance, PSD, AV, sum covariance) is
    #: proportional to; None for a deterministic component.
    scale_name: ClassVar[str | None] = None

    @abstractmethod
    def simulate(self, n: int, dt: float, rng: np.random.Generator) -> np.ndarray:
        """n samples [u] of the component's error contribution at sampling period dt [s]."""

    @abstractmethod
    def block(self, dt: float) -> StateBlock:
        """The component's state-space block at sampling period dt [s]."""

    @abstractmethod
    def allan_variance(self, tau: np.ndarray | float, dt: float) -> np.ndarray:
        """Theoretical Allan variance [u²] at averaging times tau [s]."""

    @abstractmethod
    def psd(self, f: np.ndarray | float, dt: float) -> np.ndarray:
        """Two-sided PSD [u²/Hz] at frequencies f [Hz] (dt [s] matters for sampled components)."""

    def sum_covariance(self, lag: np.ndarray, dt: float) -> np.ndarray:
        """Generalised covariance K(u) [u²] of the partial sums x_k = y_0 + … + y_{k−1} at integer lags u
        (docs/noise.md); stationary: K(u) = −½ Var(y_1 + … + y_|u|), AV(m·dt) = (6K(0) − 8K(m) + 2K(2m))/(2m²)."""
        raise NotImplementedError(f"{self.name} has no sum covariance")

    def zero_frequency_density(self, dt: float) -> float:
        """√(dt·Σ_j R(j)) [u/√Hz], the two-sided PSD at 0 Hz of the sampled component (AV → N²/τ beyond its memory);
        components white at low frequency only."""
        raise NotImplementedError(f"{self.name} is not white at low frequency")

    def memory(self, dt: float) -> tuple[float, float, float]:
        """(longest, shortest autocovariance decay time, shortest oscillation period) [s]; (0, 0, inf): memoryless."""
        return 0.0, 0.0, math.inf

    def exponential_terms(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(c [u²], s [1/s]), complex arrays with R(u) = Re Σ_j c_j e^{s_j u} at every lag u ≥ 0 of the sampled
        process (docs/noise.md); None where the autocovariance is not such a sum."""
        return None

    def exponential_term_derivatives(self) -> dict[str, tuple[np.ndarray, np.ndarray]] | None:
        """Per shape parameter (every parameter but :attr:`scale_name`), (∂c/∂ln ϑ [u²], ∂s/∂ln ϑ [1/s]) of
        :meth:`exponential_terms` in closed form; None where not given (the statistics' own differences then stand
        in)."""
        return None

    @abstractmethod
    def per_sample(self, dt: float) -> dict[str, float]:
        """Per-sample values in paper 000's notation for sampling period dt [s]."""

    @classmethod
    @abstractmethod
    def from_per_sample(cls, dt: float, **values: float) -> Component:
        """Inverse of :meth:`per_sample`."""

    @classmethod
    def from_block(cls, phi: np.ndarray, q: np.ndarray, dt: float) -> Component:
        """Inverse of :meth:`block`: the component with transition ``phi`` and process noise ``q`` at ``dt`` [s]."""
        raise NotImplementedError(f"{cls.name} has no state block to convert back from")

    def params(self) -> dict[str, float]:
        """Continuous-time parameters by name."""
        # not asdict(), which deep-copies (docs/noise.md, "Why the component protocol …")
        return {f.name: float(getattr(self, f.name)) for f in fields(self)}  # type: ignore[arg-type]

    def scale_only(self) -> tuple[float, tuple[tuple[str, float], ...]] | None:
        """(scale > 0, the other values by name) when :attr:`scale_name` is the only parameter (moments ∝ scale²),
        else None."""
        values = self.params()
        scale = values.pop(self.scale_name) if self.scale_name else 0.0
        if self.parameter_names != (self.scale_name,) or not scale > 0.0:
            return None
        return scale, tuple(sorted(values.items()))

    def __str__(self) -> str:
        inner = ", ".join(f"{k}={v:.6g}" for k, v in self.params().items())
        return f"{self.name}({inner})"
