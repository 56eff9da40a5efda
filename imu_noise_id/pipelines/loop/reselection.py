"""Re-selection after a loop step: drops, RW ↔ BI swaps, an LPF swapped for a second-order low-pass (also on the
start). Beyond the papers; why: docs/loop.md, "Why the loop's moves …"."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ...core.diagnostics import detectors as det
from ...core.errors import InputError
from ...core.estimation.readouts.kalibr import is_short_memory_osc
from ...core.noise.base import Component
from ...core.noise.components import WN
from ...core.noise.digital import DLPF
from ...core.noise.modelspec import canonical
from ...core.noise.resonant import LPF, OSC
from .rules import better, judge
from .state import Diagnosis, LoopState, Trial
from .steps import AxisLoop
from .trials import long_tau_flicker, long_tau_walk

#: Components re-selection may drop, those that absorb what the model lacks (docs/loop.md, "The loop's rules" 5).
DROPPABLE = ("RW", "GM", "QN", "RR")
#: The sensor's first-order filters, which a second-order low-pass (an OSC of short memory) may make redundant.
FIRST_ORDER = ("LPF", "MA")
#: A DLPF whose passband density an added resonance cut by at least this factor stood for that line (docs/loop.md,
#: "The loop's rules" 5): re-selection then tries dropping it.
LINE_TOOK_FILTER = 2.0


def moves(loop: AxisLoop, diag: Diagnosis, added: str, swapped: tuple[str, ...] = (),
          before: list[Component] | None = None) -> list[tuple[str, list[Component]]]:
    """Re-selection's moves, as (label, components): drop each :data:`DROPPABLE` component but ``added``; swap an RW for
    BI started from the long-τ AV; right after a GM, swap BI back for an RW of the same level; right after an LPF, swap
    it for a second-order low-pass (:func:`second_order_start`); right after an OSC of short memory
    (:func:`~imu_noise_id.core.estimation.readouts.kalibr.is_short_memory_osc`), drop each :data:`FIRST_ORDER` filter;
    right after an OSC, drop a DLPF whose passband density fell by :data:`LINE_TOOK_FILTER` or more from ``before``
    (the fit before the addition). ``swapped``: swaps already made in this re-selection, never undone."""
    fitted = list(diag.fit.components)
    moves: list[tuple[str, list[Component]]] = []
    if len(fitted) < 2:
        return moves
    names = {c.name for c in fitted}
    new = added.split("+")
    second_order = "OSC" in new and any(is_short_memory_osc(c, loop.dt) for c in fitted)
    for i, c in enumerate(fitted):
        rest = [d for j, d in enumerate(fitted) if j != i]
        redundant_filter = ((c.name in FIRST_ORDER and second_order)
                            or (isinstance(c, DLPF) and "OSC" in new and _line_took(c, before)))
        if (c.name in DROPPABLE or redundant_filter) and c.name != added:
            moves.append((f"drop {c.name}", rest))
        if isinstance(c, LPF) and "LPF" in new:
            moves.append(("swap LPF (for OSC)", second_order_start(fitted, c)))
        if c.name == "RW" and c.name != added and "BI" not in names and "BI (for RW)" not in swapped:
            moves.append(("swap RW (for BI)", canonical([*rest, long_tau_flicker(loop, diag)])))
        if (c.name == "BI" and "GM" in new and "RW" not in names and "RW (for BI)" not in swapped
                and diag.tau.size):
            moves.append(("swap BI (for RW)", canonical([*rest, long_tau_walk(diag)])))
    return moves


def _line_took(dlpf: DLPF, before: list[Component] | None) -> bool:
    """Whether ``before`` (the fit before an addition) held a DLPF of a passband density at least
    :data:`LINE_TOOK_FILTER` times ``dlpf``'s: the resonance just added took the power the filter stood for."""
    previous = [c for c in before or () if isinstance(c, DLPF)]
    return len(previous) == 1 and previous[0].noise_density >= LINE_TOOK_FILTER * dlpf.noise_density


#: Least white share of a second-order low-pass start's passband density (docs/loop.md, "Why the loop's moves …").
SECOND_ORDER_WHITE_SHARE = 0.5


def second_order_start(fitted: list[Component], lpf: LPF) -> list[Component]:
    """The fitted components with the LPF ``lpf`` replaced by a Butterworth OSC (:meth:`.OSC.low_pass`) at its cutoff,
    the passband density √(N_WN² + N_LPF²) kept, ≥ :data:`SECOND_ORDER_WHITE_SHARE` of it white. Beyond the papers."""
    white = next((c for c in fitted if isinstance(c, WN)), None)
    n_white = white.noise_density if white is not None else 0.0
    passband = math.hypot(n_white, lpf.noise_density)
    n_white = max(n_white, SECOND_ORDER_WHITE_SHARE * passband)
    filtered = OSC.low_pass(math.sqrt(passband**2 - n_white**2), lpf.cutoff)
    rest = [c for c in fitted if c is not lpf and c is not white]
    return canonical([WN(n_white), filtered, *rest])


def swap_start_filter(loop: AxisLoop, state: LoopState,
                      diag: Diagnosis) -> tuple[Trial, LoopState, Diagnosis] | None:
    """The start's LPF tried as a second-order low-pass (:func:`second_order_start`; :func:`try_move`, no BIC tie):
    (trial, state, diagnosis), the start's where the refit failed; None without an LPF."""
    lpf = next((c for c in diag.fit.components if isinstance(c, LPF)), None)
    if lpf is None:
        return None
    new_state = state.with_components(second_order_start(list(diag.fit.components), lpf))
    trial, new_diag = try_move(loop, diag, new_state, "swap LPF (for OSC)",
                               evidence="swap LPF (for OSC): the start's low-pass as a second-order one")
    return (trial, new_state, new_diag) if new_diag is not None else (trial, state, diag)


def try_move(loop: AxisLoop, diag: Diagnosis, new_state: LoopState, label: str, *,
             evidence: str | None = None) -> tuple[Trial, Diagnosis | None]:
    """Fit and judge one re-selection move ``label`` ("drop RW" …) against ``diag`` (:func:`judge`, with the BIC tie
    for a move that adds no parameter, K guarded for a drop): the trial and the new diagnosis (None when the refit
    failed)."""
    finding = det.Finding.proposed(label.split(" ", 1)[1], "reselection", evidence or label)
    try:
        new_diag = loop.diagnose(new_state)
    except (InputError, ValueError, np.linalg.LinAlgError) as exc:
        return Trial(finding, new_state.name(), None, False, f"{label}: refit failed: {exc}"), None
    ok, why = judge(diag, new_diag, tie=new_diag.fit.n_params <= diag.fit.n_params,
                    guard_walk=label.startswith("drop"))
    return Trial(finding, new_state.name(), new_diag.errors.bic, ok, f"{label}: {why}"), new_diag


#: A drop whose exact fit's log-likelihood exceeds the current fit's by more than this shows the current fit short of
#: its maximum: a nested structure cannot fit better (:func:`climb_from_nested`).
NESTED_SLACK = 1.0
#: The dropped component restored beside the nested fit starts at this share of its scale.
RESTORED_SHARE = 0.1
#: Refits from a nested fit one re-selection may make (each one exact fit).
MAX_CLIMBS = 2


def climb_from_nested(loop: AxisLoop, state: LoopState, diag: Diagnosis, nested: Diagnosis,
                      dropped: Component) -> tuple[Trial, LoopState, Diagnosis] | None:
    """The current structure refitted from a drop's fit ``nested`` with ``dropped`` restored at
    :data:`RESTORED_SHARE` of its scale, when ``nested``'s log-likelihood exceeds ``diag``'s by more than
    :data:`NESTED_SLACK` (exact fits only: on the composite likelihood both are evaluated at a maximiser of another
    likelihood, where a nested structure may lie higher). (trial, state, diagnosis) where the refit lies higher than
    ``diag``, else None. Beyond the papers: every re-selection move is judged against the current fit, and one that
    stopped in a poor local maximum made a drop look worth thousands of BIC units (docs/loop.md, "The loop's rules")."""
    if (loop.on_composite or dropped.scale_name is None
            or not nested.fit.loglik > diag.fit.loglik + NESTED_SLACK):
        return None
    scale = getattr(dropped, dropped.scale_name)
    start = canonical([*nested.fit.components, replace(dropped, **{dropped.scale_name: RESTORED_SHARE * scale})])
    new_state = state.with_components(start)
    finding = det.Finding.proposed("refit", "reselection", f"{state.name()} refitted from its nested fit")
    try:
        new_diag = loop.diagnose(new_state)
    except (InputError, ValueError, np.linalg.LinAlgError):  # InputError is a ValueError
        return None
    if not new_diag.fit.loglik > diag.fit.loglik:
        return None
    reason = (f"refit from the fit without {dropped.name}: log-likelihood {diag.fit.loglik:.1f} → "
              f"{new_diag.fit.loglik:.1f} (the nested fit's {nested.fit.loglik:.1f} showed the fit short of its "
              f"maximum)")
    return Trial(finding, new_state.name(), new_diag.errors.bic, True, reason), new_state, new_diag


def _dropped(diag: Diagnosis, components: list[Component]) -> Component | None:
    """The one component of ``diag``'s fit that ``components`` lacks, or None."""
    kept = list(components)
    missing = []
    for c in diag.fit.components:
        if c in kept:
            kept.remove(c)
        else:
            missing.append(c)
    return missing[0] if len(missing) == 1 else None


def reselect(loop: AxisLoop, state: LoopState, diag: Diagnosis, added: str,
             before: list[Component] | None = None) -> tuple[LoopState, Diagnosis, list[str], list[Trial]]:
    """Re-selection after an addition (``before``: the fit's components before it): every move of :func:`moves`
    fitted (:func:`try_move`), the best kept (:func:`better`), repeated while one is kept. Where a drop fits better
    than the current fit, the current structure is first refitted from the best such drop (:func:`climb_from_nested`,
    at most :data:`MAX_CLIMBS` times) and the moves are tried again against that refit. Returns (state, diagnosis,
    dropped labels, trials)."""
    dropped: list[str] = []
    trials: list[Trial] = []
    climbs = 0
    while True:
        best: tuple[LoopState, Diagnosis, str] | None = None
        tried: list[Trial] = []
        nested: list[tuple[Diagnosis, Component]] = []
        for label, components in moves(loop, diag, added, tuple(dropped), before):
            new_state = state.with_components(components)
            trial, new_diag = try_move(loop, diag, new_state, label)
            tried.append(trial)
            if new_diag is None:
                continue
            if label.startswith("drop") and (gone := _dropped(diag, components)) is not None:
                nested.append((new_diag, gone))
            if trial.accepted and (best is None or better(new_diag, best[1])):
                best = (new_state, new_diag, trial.finding.effect)
        if nested and climbs < MAX_CLIMBS:
            highest, gone = max(nested, key=lambda n: n[0].fit.loglik)
            refit = climb_from_nested(loop, state, diag, highest, gone)
            if refit is not None:  # the moves judged against a fit short of its maximum are tried again
                climbs += 1
                trials.append(refit[0])
                state, diag = refit[1], refit[2]
                continue
        trials += tried
        if best is None:
            return state, diag, dropped, trials
        state, diag = best[0], best[1]
        dropped.append(best[2])
