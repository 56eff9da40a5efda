"""A fitted Gauss–Markov process with a memory of a few samples is the sensor's own low-pass filter (LPF).

Beyond paper 000. A first-order GM with correlation time τ of a sample or two is, to the likelihood, exactly the
white noise of the sensor's first-order low-pass filter of cutoff f_c = 1/(2πτ) (the same state-space block; see
:class:`~imu_noise_id.core.noise.resonant.LPF`), and it is what a WN+GM fit does with a DLPF-filtered sensor.
Read as a GM it is a bias process of absurd τ; read as an LPF its noise density N = σ√(2τ) is the passband
white-noise density that belongs with the white noise. :func:`gm_as_filter` renames such a component and
its parameters, nothing else (likelihood, state space and innovations are unchanged).
"""

from __future__ import annotations

import math
from dataclasses import replace

from ..noise.components import GM
from ..noise.modelspec import structure_name
from ..noise.resonant import LPF
from .results import FitResult

#: A GM whose τ is below this many sampling periods is read as the sensor's low-pass filter.
FILTER_MAX_TAU_SAMPLES = 5


def gm_as_filter(fit: FitResult) -> FitResult:
    """``fit`` with its shortest GM renamed LPF when τ < :data:`FILTER_MAX_TAU_SAMPLES`·dt and the model has no LPF.

    The cutoff's interval is the τ interval mapped through f_c = 1/(2πτ); the noise density's interval is not
    carried over (it depends on σ and τ jointly) and is left out of ``se``/``ci95``.
    """
    gms = [(i, c) for i, c in enumerate(fit.components) if isinstance(c, GM)]
    if not gms or any(isinstance(c, LPF) for c in fit.components):
        return fit
    i, gm = min(gms, key=lambda ic: ic[1].tau)
    if gm.tau >= FILTER_MAX_TAU_SAMPLES * fit.dt:
        return fit
    components = list(fit.components)
    components[i] = LPF.from_gm(gm.tau, gm.sigma)
    key = "GM" if len(gms) == 1 else f"GM{[j for j, _ in gms].index(i) + 1}"
    se = {k: v for k, v in fit.se.items() if not k.startswith(f"{key}.")}
    ci95 = {k: v for k, v in fit.ci95.items() if not k.startswith(f"{key}.")}
    if f"{key}.tau" in fit.ci95:
        lo, hi = fit.ci95[f"{key}.tau"]
        ci95["LPF.cutoff"] = (1.0 / (2.0 * math.pi * hi) if hi > 0 else 0.0,
                              1.0 / (2.0 * math.pi * lo) if lo > 0 else math.inf)
    return replace(fit, model=structure_name([c.name for c in components]), components=components, se=se,
                   ci95=ci95)
