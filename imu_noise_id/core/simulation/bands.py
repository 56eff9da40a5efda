"""Allan variances of simulations of a fitted model: the band a record's AV should fall in if the model is right
(paper 000 figs. 4, 6, 7 draw the record's AV, thick, against the AVs of simulations of the fitted model, thin)."""

from __future__ import annotations

import numpy as np

from ..allan import allan_variance, choose_m
from ..noise.components import Component, simulate_sum


def allan_band(components: list[Component], dt: float, n: int, tau: np.ndarray | None = None, *, n_sim: int = 20,
               seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """AVs of ``n_sim`` simulations of ``components`` (n samples at ``dt`` [s]): (tau [s], avar [u²] (n_sim, len(tau)));
    ``tau`` defaults to :func:`~imu_noise_id.core.allan.choose_m`'s grid, given values rounded to multiples of dt."""
    m = choose_m(n) if tau is None else np.unique(np.maximum(np.round(np.asarray(tau, float) / dt), 1))
    rng = np.random.default_rng(seed)
    rows = [allan_variance(simulate_sum(components, n, dt, rng), dt, m=m).variance[:, 0] for _ in range(n_sim)]
    return m * dt, np.array(rows)
