"""Re-selection after a loop step (issue 11's rules on real data): dropping what an addition made redundant,
swapping a random walk and flicker noise for one another, and the sensor's first-order low-pass for a
second-order one (also tried on the start)."""

from __future__ import annotations

import math

import numpy as np

from ...core.diagnostics import detectors as det
from ...core.errors import InputError
from ...core.estimation.kalibr import is_short_memory_osc
from ...core.noise.base import Component
from ...core.noise.components import WN
from ...core.noise.resonant import LPF, OSC
from .rules import better, judge
from .state import Diagnosis, LoopState, Trial
from .steps import AxisLoop, _canonical
from .trials import long_tau_flicker, long_tau_walk

#: Components re-selection may drop: those that absorb what the model lacks (an RW the short-term predictability
#: of an oscillation, a GM the sensor's low-pass); lines and the low-pass were each added on their own evidence.
DROPPABLE = ("RW", "GM", "QN", "RR")
#: The sensor's first-order filters, which a second-order low-pass (an OSC of short memory) may make redundant.
FIRST_ORDER = ("LPF", "MA")



def moves(loop: AxisLoop, diag: Diagnosis, added: str,
          swapped: tuple[str, ...] = ()) -> list[tuple[str, list[Component]]]:
    """Re-selection's moves from the fitted components: drop each :data:`DROPPABLE` one but ``added``, swap a
    random walk for flicker noise (BI) started from the long-τ AV, and, right after a GM was added, swap flicker noise
    back for a random walk started from the same level; right after an LPF was added, swap it for a second-order
    low-pass (:func:`second_order_start`), and right after an OSC was added, when the model holds one of short memory
    (:func:`~imu_noise_id.core.estimation.kalibr.is_short_memory_osc`), drop each :data:`FIRST_ORDER` filter it may
    have made redundant. ``swapped``: what this re-selection already swapped (``"RW (for BI)"``), never undone
    within it.

    The swaps are beyond the papers. On 20 min of the ADIS16405 accelerometers a random walk 3–5× larger than the
    long-τ AV supports and flicker noise fit to within 2–3 in log-likelihood (the likelihood rests on the few
    Fourier frequencies below 0.05 Hz), while the random walk's AV is 10× the data's at τ = 100 s and the flicker's
    follows it (``bench/loop_measured.py``). The way back: flicker noise that replaced a random walk while a
    short-memory GM was still unmodelled stands in for both; once the GM is added, the random walk it displaced
    fits better (``bench_loop_effects.py``'s ``osc+clear_gm``: without the way back the final model kept no random
    walk in 9 of 10 records). Only after a GM: offered after any addition, the way back also took the flicker from
    ADIS16405 run 5 accel_y after its second OSC, whose final AV then left the data's band (z 0.5 → 1.7). Same
    number of parameters: the BIC tie rule of :func:`judge` applies; the second-order low-pass has one more than
    the LPF it replaces and needs a lower BIC, as an addition does.
    """
    fitted = list(diag.fit.components)
    moves: list[tuple[str, list[Component]]] = []
    if len(fitted) < 2:
        return moves
    names = {c.name for c in fitted}
    new = added.split("+")
    second_order = "OSC" in new and any(is_short_memory_osc(c, loop.dt) for c in fitted)
    for i, c in enumerate(fitted):
        rest = [d for j, d in enumerate(fitted) if j != i]
        if (c.name in DROPPABLE or (c.name in FIRST_ORDER and second_order)) and c.name != added:
            moves.append((f"drop {c.name}", rest))
        if isinstance(c, LPF) and "LPF" in new:
            moves.append(("swap LPF (for OSC)", second_order_start(fitted, c)))
        if c.name == "RW" and c.name != added and "BI" not in names and "BI (for RW)" not in swapped:
            moves.append(("swap RW (for BI)", _canonical([*rest, long_tau_flicker(loop, diag)])))
        if (c.name == "BI" and "GM" in new and "RW" not in names and "RW (for BI)" not in swapped
                and diag.tau.size):
            moves.append(("swap BI (for RW)", _canonical([*rest, long_tau_walk(diag)])))
    return moves


#: Share of the passband density a second-order low-pass put in a first-order one's place leaves white at its start.
SECOND_ORDER_WHITE_SHARE = 0.5


def second_order_start(fitted: list[Component], lpf: LPF) -> list[Component]:
    """The fitted components with the first-order low-pass ``lpf`` replaced by a second-order one (a Butterworth
    OSC, :meth:`~imu_noise_id.core.noise.resonant.OSC.low_pass`) at its cutoff, the passband density √(N_WN² +
    N_LPF²) kept and at least :data:`SECOND_ORDER_WHITE_SHARE` of it white.

    Beyond the papers (issue 11's sensor filter, "an AR(1)/AR(2) on the white part"). Many MEMS parts filter with a
    second-order low-pass, which the loop, offering a GM of a few samples' memory as a first-order LPF or an MA,
    fits as an LPF: the white noise beside it goes to ~0 (the LPF's slower roll-off carries it), N reads ≈ 3 %
    high and its interval misses the truth (``bench/studies/probe_lpf2_filter_shape.py``: WN + LPF + RW 40 in BIC above
    the true WN + OSC + RW on 20 min records of ``bench_loop_effects.py``'s ``lpf2``). The white part restarts
    above ~0 because the likelihood is flat in its logarithm there: on seed 1000 of ``lpf2``, from the LPF fit's
    ~0 white noise the search stayed at an OSC on its bandwidth's bound, 605 below the optimum in log-likelihood;
    from a white share of 0.5 it came within 1.1 of it (0.3: within 17).
    """
    white = next((c for c in fitted if isinstance(c, WN)), None)
    n_white = white.noise_density if white is not None else 0.0
    passband = math.hypot(n_white, lpf.noise_density)
    n_white = max(n_white, SECOND_ORDER_WHITE_SHARE * passband)
    filtered = OSC.low_pass(math.sqrt(passband**2 - n_white**2), lpf.cutoff)
    rest = [c for c in fitted if c is not lpf and c is not white]
    return _canonical([WN(n_white), filtered, *rest])


def swap_start_filter(loop: AxisLoop, state: LoopState,
                      diag: Diagnosis) -> tuple[Trial, LoopState, Diagnosis] | None:
    """The start's LPF (the model selection's short-memory GM, read as the sensor's filter) tried as a
    second-order low-pass (:func:`second_order_start`), as re-selection tries an LPF the loop adds and by the same
    rules (:func:`try_move`: it adds a parameter, so no BIC tie): the trial, its state and diagnosis (the start's
    where the refit failed); None without an LPF."""
    lpf = next((c for c in diag.fit.components if isinstance(c, LPF)), None)
    if lpf is None:
        return None
    new_state = state.with_components(second_order_start(list(diag.fit.components), lpf))
    trial, new_diag = try_move(loop, diag, new_state, "swap LPF (for OSC)",
                               evidence="swap LPF (for OSC): the start's low-pass as a second-order one")
    return (trial, new_state, new_diag) if new_diag is not None else (trial, state, diag)


def try_move(loop: AxisLoop, diag: Diagnosis, new_state: LoopState, label: str, *,
             evidence: str | None = None) -> tuple[Trial, Diagnosis | None]:
    """Fit and judge one re-selection move (``label``: "drop RW", "swap LPF (for OSC)" …) against ``diag``: the
    BIC and do-no-harm rules, with the BIC tie the AV may break (:func:`judge`) for a move that adds no parameter
    (a drop, an equal-size swap; the second-order low-pass adds one, as an addition does). The trial and the new
    diagnosis (None when the refit failed)."""
    finding = det.Finding(effect=label.split(" ", 1)[1], detector="reselection", statistic=0.0, threshold=0.0,
                          log10_p=0.0, level=0.0, params={}, evidence=evidence or label)
    try:
        new_diag = loop.diagnose(new_state)
    except (InputError, ValueError, np.linalg.LinAlgError) as exc:
        return Trial(finding, new_state.name(), None, False, f"{label}: refit failed: {exc}"), None
    ok, why = judge(diag, new_diag, tie=new_diag.fit.n_params <= diag.fit.n_params)
    return Trial(finding, new_state.name(), new_diag.errors.bic, ok, f"{label}: {why}"), new_diag


def reselect(loop: AxisLoop, state: LoopState, diag: Diagnosis,
              added: str) -> tuple[LoopState, Diagnosis, list[str], list[Trial]]:
    """Re-selection after an addition: try every move of :func:`moves` (drops, the RW↔BI swaps, the second-order
    low-pass; :func:`try_move`); the best kept by the BIC and do-no-harm rules, or by the AV when the BIC ties on a
    move that adds no parameter (:func:`judge`); repeated while one is kept (an RW that absorbed an oscillation goes
    once the oscillation is modelled)."""
    dropped: list[str] = []
    trials: list[Trial] = []
    while True:
        best: tuple[LoopState, Diagnosis, str] | None = None
        for label, components in moves(loop, diag, added, tuple(dropped)):
            new_state = state.with_components(components)
            trial, new_diag = try_move(loop, diag, new_state, label)
            trials.append(trial)
            if trial.accepted and (best is None or better(new_diag, best[1])):
                best = (new_state, new_diag, trial.finding.effect)
        if best is None:
            return state, diag, dropped, trials
        state, diag = best[0], best[1]
        dropped.append(best[2])
