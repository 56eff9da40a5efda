"""Probe: would re-selection swapping the random walk for a Gauss–Markov process (as it swaps it for flicker) let an
ADIS16405 accelerometer keep a smaller K? The loop from WN+RW on one axis with that extra move at every step.

Usage (from the repository root)::

    PYTHONPATH=$PWD python bench/studies/probe_rw_gm_swap.py RUN AXIS [--samples N] [--out FILE]

The extra move replaces the fitted RW by a GM of τ a tenth of the record and σ from the long-τ AV (the joint
search's start, ``trials.explore``); everything else is the loop's. Prints the trace of ``bench/studies/loop_trace.py``.
Written for run 4 accel_z, whose RW (1.3·10⁻³ m/s²/√s) lies above the long-τ AV's simultaneous 95 % bound.
"""

from __future__ import annotations

import math

import loop_trace  # bench/studies/loop_trace.py, beside this script

from imu_noise_id.core.noise.base import Component
from imu_noise_id.core.noise.components import GM
from imu_noise_id.pipelines.loop import reselection, trials
from imu_noise_id.pipelines.loop.state import Diagnosis
from imu_noise_id.pipelines.loop.steps import AxisLoop

#: The re-selection moves of the loop as it is.
LOOP_MOVES = reselection.moves


def moves_with_gm_swap(loop: AxisLoop, diag: Diagnosis, added: str, swapped: tuple[str, ...] = (),
                       before: list[Component] | None = None) -> list[tuple[str, list[Component]]]:
    """:func:`reselection.moves` plus "swap RW (for GM)"."""
    out = LOOP_MOVES(loop, diag, added, swapped, before)
    fitted = list(diag.fit.components)
    if added == "RW" or any(c.name == "GM" for c in fitted):
        return out
    for i, c in enumerate(fitted):
        if c.name == "RW":
            gm = GM(tau=loop.n * loop.dt / 10.0, sigma=math.sqrt(max(trials.long_tau_level(diag), 1e-30) / 0.38))
            out.append(("swap RW (for GM)", trials._canonical([*fitted[:i], *fitted[i + 1:], gm])))
    return out


def main(argv: list[str] | None = None) -> int:
    reselection.moves = moves_with_gm_swap  # reselect() looks it up in its module
    return loop_trace.main(argv, script="bench/studies/probe_rw_gm_swap.py", description=__doc__)


if __name__ == "__main__":
    raise SystemExit(main())
