"""EM and GMWM compared parameter by parameter (beyond the papers): from 95 % intervals s = ln(hi/lo)/(2·1.96),
z = ln(θ_GMWM/θ_EM)/√(s_EM² + s_GMWM²), agree when |z| ≤ 1.96; a ramp's signed slope linearly,
s = (hi − lo)/(2·1.96); "undetermined" without finite intervals. Different structures: Kalibr's N and K compared.
GMWM scales with |z| > :data:`MISFIT_Z` are listed as misfit."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...noise.modelspec import parameter_labels
from ..em.results import FitResult
from . import kalibr
from .quantiles import Z95

#: A GMWM scale whose standardised residual exceeds this misfits.
MISFIT_Z = 2.0


@dataclass(frozen=True)
class Agreement:
    """One quantity compared: its two estimates with intervals, their ratio, z and the verdict."""

    quantity: str
    em: float
    em_ci: tuple[float, float]
    gmwm: float
    gmwm_ci: tuple[float, float]
    ratio: float
    z: float
    verdict: str  # "agree", "differ" or "undetermined"


@dataclass(frozen=True)
class Comparison:
    """EM against GMWM on one axis."""

    em_model: str
    gmwm_model: str
    rows: list[Agreement]
    misfit_tau: list[float]
    j_p_value: float

    @property
    def agree(self) -> bool:
        return all(r.verdict != "differ" for r in self.rows)

    @property
    def verdict(self) -> str:
        differ = [r.quantity for r in self.rows if r.verdict == "differ"]
        where = (f"; the GMWM misfits the wavelet variance at tau = {', '.join(f'{t:.3g}' for t in self.misfit_tau)} s"
                 if self.misfit_tau else "")
        structure = ("" if self.em_model == self.gmwm_model
                     else f" (EM chose {self.em_model}, GMWM {self.gmwm_model}: N and K compared)")
        if not differ:
            return f"EM and GMWM agree within their intervals{structure}{where}"
        return (f"EM and GMWM differ on {', '.join(differ)}{structure}: the model is wrong somewhere{where}; "
                f"GMWM J-test p = {self.j_p_value:.3g}")


def _log_sd(ci: tuple[float, float]) -> float:
    lo, hi = ci
    if not (lo > 0 and math.isfinite(hi) and hi > lo):
        return math.inf
    return math.log(hi / lo) / (2.0 * Z95)


def _row(quantity: str, em: float, em_ci, gm: float, gm_ci, *, linear: bool = False) -> Agreement:
    """One compared quantity: z in log scale, or on the linear scale for a signed one (module docstring)."""
    em_ci, gm_ci = tuple(em_ci), tuple(gm_ci)
    ratio = gm / em if em else math.nan
    if linear:
        sd = math.hypot(em_ci[1] - em_ci[0], gm_ci[1] - gm_ci[0]) / (2.0 * Z95)
        determined = math.isfinite(sd) and sd > 0
    else:
        sd = math.hypot(_log_sd(em_ci), _log_sd(gm_ci))
        determined = em > 0 and gm > 0 and math.isfinite(sd)
    if not determined:
        return Agreement(quantity, em, em_ci, gm, gm_ci, ratio, math.nan, "undetermined")
    z = (gm - em) / sd if linear else math.log(gm / em) / sd
    return Agreement(quantity, em, em_ci, gm, gm_ci, ratio, z, "agree" if abs(z) <= Z95 else "differ")


def _keyed(fit: FitResult) -> dict[tuple[str, int, str], tuple[str, float, tuple[float, float]]]:
    """(type, rank by τ, parameter) → (label, value, interval); magnitudes except the ramp's signed slope."""
    ranked: dict[int, int] = {}
    for name in {c.name for c in fit.components}:
        same = [i for i, c in enumerate(fit.components) if c.name == name]
        same.sort(key=lambda i: fit.components[i].params().get("tau", 0.0))
        ranked.update({i: r for r, i in enumerate(same)})
    out = {}
    for i, p, label in parameter_labels(list(fit.components)):
        if label in fit.ci95:
            lo, hi = fit.ci95[label]
            value = fit.components[i].params()[p]
            if fit.components[i].name != "RR":
                value, lo, hi = abs(value), min(abs(lo), abs(hi)), max(abs(lo), abs(hi))
            out[(fit.components[i].name, ranked[i], p)] = (label, value, (lo, hi))
    return out


def compare(em: FitResult, gmwm: FitResult) -> Comparison:
    """Compare an EM and a GMWM fit (:class:`~..gmwm.fit.GmwmFit`) of one axis."""
    rows = []
    if em.model == gmwm.model:
        mine, theirs = _keyed(em), _keyed(gmwm)
        for key, (label, g_val, g_ci) in theirs.items():
            if key in mine:
                _, e_val, e_ci = mine[key]
                rows.append(_row(label, e_val, e_ci, g_val, g_ci, linear=key[0] == "RR"))
    else:
        for name, getter in (("N (Kalibr noise density)", kalibr.noise_density),
                             ("K (Kalibr random walk)", kalibr.random_walk)):
            e, g = getter(em), getter(gmwm)
            if e.value is not None and g.value is not None:
                rows.append(_row(name, e.value, e.ci95, g.value, g.ci95))
    z = np.asarray(getattr(gmwm, "residual_z", np.zeros(0)))
    tau = gmwm.wv.tau if getattr(gmwm, "wv", None) is not None else np.zeros(0)
    misfit = [float(t) for t, v in zip(tau, z, strict=False) if abs(v) > MISFIT_Z]
    return Comparison(em.model, gmwm.model, rows, misfit, float(getattr(gmwm, "p_value", math.nan)))
