"""Streaming Ljung–Box and NIS on an online filter's last ``window`` innovations (docs/loop.md): update O(1), status
O(w·log w)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .consistency import nis_bounds
from .residuals import ljung_box


@dataclass(frozen=True)
class MonitorStatus:
    """The window's verdict: ``ok``, ``ljung_box_p``, ``worst_lag``, ``worst_rho``, ``nis_mean``, ``nis_interval``,
    ``n``, ``message``."""

    ok: bool
    ljung_box_p: float
    worst_lag: int
    worst_rho: float
    nis_mean: float
    nis_interval: tuple[float, float]
    n: int
    message: str


class InnovationMonitor:
    """Ring buffer of the last ``window`` (≥ 50) standardised innovations; Ljung–Box over ``lags`` and NIS at
    ``alpha``."""

    def __init__(self, window: int = 2000, lags: int = 10, alpha: float = 1e-3) -> None:
        if window < 50:
            raise ValueError(f"window must be >= 50 innovations, got {window}")
        if not 1 <= lags < window // 4:
            raise ValueError(f"lags must be in [1, window/4), got {lags}")
        if not 0 < alpha < 1:
            raise ValueError(f"alpha must be in (0, 1), got {alpha}")
        self.window, self.lags, self.alpha = int(window), int(lags), float(alpha)
        self._e = np.zeros(self.window)
        self._nis = np.zeros(self.window)
        self._count = 0

    @property
    def ready(self) -> bool:
        """Whether the buffer holds a full window."""
        return self._count >= self.window

    def update(self, innovation: float, variance: float) -> None:
        """Add one scalar innovation ν [u] with its predicted variance S [u²] (> 0)."""
        if not (variance > 0 and math.isfinite(variance) and math.isfinite(innovation)):
            raise ValueError(f"innovation must be finite and its variance > 0, got {innovation!r}, {variance!r}")
        i = self._count % self.window
        self._e[i] = innovation / math.sqrt(variance)
        self._nis[i] = innovation**2 / variance
        self._count += 1

    def update_nis(self, nis: float, dim: int) -> None:
        """Add a vector innovation's NIS νᵀS⁻¹ν of dimension ``dim`` (NIS test only)."""
        if not (nis >= 0 and math.isfinite(nis)) or dim < 1:
            raise ValueError("NIS must be finite and >= 0 and dim >= 1")
        i = self._count % self.window
        self._e[i] = math.nan
        self._nis[i] = nis / dim
        self._count += 1

    def _ordered(self, a: np.ndarray) -> np.ndarray:
        n = min(self._count, self.window)
        if self._count <= self.window:
            return a[:n]
        i = self._count % self.window
        return np.concatenate([a[i:], a[:i]])

    def status(self) -> MonitorStatus:
        """Test the window (at least ``4·lags`` innovations)."""
        n = min(self._count, self.window)
        if n < 4 * self.lags:
            raise ValueError(f"only {n} innovations buffered; need {4 * self.lags}")
        e = self._ordered(self._e)
        nis = self._ordered(self._nis)
        nis_mean = float(np.mean(nis))
        lo, hi = nis_bounds(1, n, self.alpha)
        problems = []
        lb_p, lag, rho = math.nan, 0, math.nan
        if np.isfinite(e).sum() >= 4 * self.lags:
            lb = ljung_box(e, self.lags)
            lb_p, lag, rho = lb.p_value, lb.worst_lag, lb.worst_rho
            if lb_p < self.alpha:
                problems.append(f"residuals correlated at lag {lag} (ρ = {rho:.2f}, Ljung–Box p = {lb_p:.1e})")
        if not lo <= nis_mean <= hi:
            word = "larger" if nis_mean > hi else "smaller"
            problems.append(f"innovations {word} than predicted (mean NIS {nis_mean:.2f}, "
                            f"expected {lo:.2f}–{hi:.2f})")
        message = ("model inadequate: " + "; ".join(problems)) if problems else (
            f"residuals white and consistent over the last {n} samples")
        return MonitorStatus(ok=not problems, ljung_box_p=lb_p, worst_lag=lag, worst_rho=rho, nis_mean=nis_mean,
                             nis_interval=(lo, hi), n=n, message=message)
