"""What an axis of a unit should look like: its reference from an earlier analysis (N with its interval, final model,
known lines, K's interval), the model the step and line tests whiten with, and the rate check."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..estimation.readouts.kalibr import is_short_memory_osc
from ..noise.base import Component
from ..noise.components import RW, WN, total_allan_variance
from ..noise.resonant import OSC

#: Largest relative difference between a recording's rate and its reference's.
RATE_TOLERANCE = 0.02
#: Relative tolerance of a reference density given without a usable interval (±10 %).
DEFAULT_TOLERANCE = 0.10
#: Shift of a resonance's frequency, relative to it, within which a line is still the reference's resonance: an
#: environmental vibration moves from one recording to the next (docs/analysis.md, "Why a line inside the
#: reference's resonance is not new").
RESONANCE_SHIFT = 0.2


@dataclass(frozen=True)
class AxisReference:
    """An axis's reference: N [u/√Hz] and its 95 % interval ((nan, nan): none), final model (None: WN), known lines
    [Hz], K's 95 % interval [u/s/√Hz] (None: none given)."""

    noise_density: float
    noise_density_ci: tuple[float, float]
    components: list[Component] | None = None
    known_lines: tuple[float, ...] = ()
    random_walk_ci: tuple[float, float] | None = None

    def model(self, dt: float) -> list[Component]:
        return list(self.components) if self.components else [WN(self.noise_density)]

    def step_model(self, dt: float) -> list[Component]:
        """The model the step and line tests whiten with: :meth:`model` with its random walk at the upper end of K's
        interval (one added there where the model has none and the end is above 0), the most slow wander the
        reference allows, so that a walk the calibration record underestimated is not taken for steps; why:
        docs/analysis.md, "Why the watch's step test reads the scan's own correlation"."""
        model = self.model(dt)
        high = self.random_walk_ci[1] if self.random_walk_ci is not None else math.nan
        if not (math.isfinite(high) and high > 0.0):
            return model
        if not any(isinstance(c, RW) for c in model):
            return [*model, RW(high)]
        return [RW(max(high, c.random_walk)) if isinstance(c, RW) else c for c in model]

    def resonance_bands(self, dt: float) -> tuple[tuple[float, float], ...]:
        """The bands [Hz] of the final model's resonances at ``dt`` [s] (each OSC but those of short memory, which
        are the sensor's filter): f₀ ± (B/2 + :data:`RESONANCE_SHIFT`·f₀) for a resonance at f₀ of half-power bandwidth
        B. A line inside one is the reference's resonance, not a new line."""
        return tuple((c.frequency - half, c.frequency + half) for c in self.components or ()
                     if isinstance(c, OSC) and not is_short_memory_osc(c, dt)
                     for half in (c.bandwidth / 2.0 + RESONANCE_SHIFT * c.frequency,))

    def density_interval(self) -> tuple[tuple[float, float], str]:
        """N's 95 % interval [u/√Hz] (±:data:`DEFAULT_TOLERANCE` without one) and a note saying which."""
        lo, hi = self.noise_density_ci
        if math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= self.noise_density <= hi:
            return (lo, hi), ""
        tol = DEFAULT_TOLERANCE
        return ((1 - tol) * self.noise_density, (1 + tol) * self.noise_density), (
            f"the reference's N has no interval: ±{100 * tol:g} % used")

    def pair_variance(self, tau: float, dt: float) -> float:
        """2·AV(τ) [u²] of the reference model at ``dt`` [s]: variance of consecutive τ-means' difference."""
        return 2.0 * float(total_allan_variance(self.model(dt), np.array([tau]), dt)[0])

    def difference_variance(self, dt: float) -> tuple[float, tuple[float, float], str]:
        """E[(y_{t+1} − y_t)²] = 2·AV(dt) [u²] of the reference, its interval (from N's) and note."""
        v = self.pair_variance(dt, dt)
        (lo, hi), note = self.density_interval()
        return v, (v * (lo / self.noise_density) ** 2, v * (hi / self.noise_density) ** 2), note

    def difference_variance_at(self, noise_density: float, dt: float) -> float:
        """E[(y_{t+1} − y_t)²] [u²] of the reference model scaled to density ``noise_density`` [u/√Hz]."""
        return self.difference_variance(dt)[0] * (noise_density / self.noise_density) ** 2


def rate_mismatch(rate_hz: float, reference_rate_hz: float, source: str) -> str | None:
    """Why a recording at ``rate_hz`` cannot be compared with a reference at ``reference_rate_hz``, or None."""
    if abs(rate_hz - reference_rate_hz) <= RATE_TOLERANCE * reference_rate_hz:
        return None
    made = f"the reference {source}" if source else "the reference"
    return (f"{made} was made at {reference_rate_hz:.6g} Hz, this IMU runs at {rate_hz:.6g} Hz: compare against an "
            "analysis of a recording at the same rate")
