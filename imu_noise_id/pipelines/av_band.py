"""Where a closed loop's final model lies against the data's 95 % Allan band (``loop.rules.av_inside_band``), as the
one sentence (:meth:`AvBandClaim.sentence`) of ``report.html``, ``model.yaml`` (``loop_verdict``) and the console."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.constants import CONFIDENCE_95
from .loop import LoopResult
from .loop.rules import simultaneous_z


@dataclass(frozen=True)
class AvBandClaim:
    """The final model's AV against the data's band: ``level`` its coverage (0.95), simultaneous over τ (Bonferroni
    over the octaves spanned); ``inside``: at every τ compared (the loop's ``av_inside_band``); ``outside``: τ ranges
    [s] (runs of neighbouring grid τ) outside it; ``n_tau``, ``n_outside``: τ compared (finite z-score), and of them
    outside; ``max_rel_av_error``: largest |AV_model / AV_data − 1| over τ."""

    level: float
    inside: bool
    outside: tuple[tuple[float, float], ...]
    n_tau: int
    n_outside: int
    max_rel_av_error: float

    def where(self) -> str:
        """Where it is outside the band: ``"every τ"``, ``"τ = 12.8–327 s"`` (ranges joined by ", "), else ``""``."""
        if self.inside or self.n_tau == 0:
            return ""
        if self.n_outside == self.n_tau:
            return "every τ"
        return "τ = " + ", ".join(f"{lo:.3g} s" if lo == hi else f"{lo:.3g}–{hi:.3g} s" for lo, hi in self.outside)

    def sentence(self) -> str:
        """The claim's sentence ("The final model's Allan variance lies outside the data's 95 % band (simultaneous over
        τ) at τ = 12.8–327 s (6 of 14 τ) and inside it elsewhere (largest relative AV error 45 %).")."""
        band = f"the data's {100 * self.level:.0f} % band (simultaneous over τ)"
        err = (f"largest relative AV error {100 * self.max_rel_av_error:.0f} %"
               if math.isfinite(self.max_rel_av_error) else "no relative AV error")
        if self.n_tau == 0:
            return f"The final model's Allan variance could not be compared with {band}: no τ has a finite interval."
        if self.inside:
            return f"The final model's Allan variance lies inside {band} at every τ ({err})."
        if self.n_outside == self.n_tau:
            return f"The final model's Allan variance lies outside {band} at every τ ({err})."
        return (f"The final model's Allan variance lies outside {band} at {self.where()} ({self.n_outside} of "
                f"{self.n_tau} τ) and inside it elsewhere ({err}).")

    def as_dict(self) -> dict:
        """``loop_verdict``'s ``av_outside_band_tau`` ([[lo, hi], …] [s]; [] inside), ``av_band`` (:meth:`sentence`)."""
        return {"av_outside_band_tau": [[float(f"{lo:.4g}"), float(f"{hi:.4g}")] for lo, hi in self.outside],
                "av_band": self.sentence()}


def av_band_claim(result: LoopResult, level: float = CONFIDENCE_95) -> AvBandClaim:
    """The claim for ``result``'s final step, from the z-scores and simultaneous bound the loop's verdict used
    (``inside`` equals ``result.av_inside_band`` for ``level`` 0.95)."""
    diag = result.final.diagnosis
    z, ok, bound = simultaneous_z(diag, level)
    tau = np.asarray(diag.tau, dtype=float)
    out = ok & (np.abs(np.where(ok, z, 0.0)) > bound)
    compared = np.flatnonzero(ok)
    runs: list[tuple[float, float]] = []
    run: tuple[float, float] | None = None
    for i in compared:  # runs of neighbouring compared τ that are all outside
        if out[i]:
            run = (float(tau[i]), float(tau[i])) if run is None else (run[0], float(tau[i]))
        elif run is not None:
            runs.append(run)
            run = None
    if run is not None:
        runs.append(run)
    n_out = int(out.sum())
    return AvBandClaim(level=level, inside=bool(ok.any() and n_out == 0), outside=tuple(runs),
                       n_tau=int(compared.size), n_outside=n_out, max_rel_av_error=float(result.max_rel_av_error))
