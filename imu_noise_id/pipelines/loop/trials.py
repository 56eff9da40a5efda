"""The moves a loop step tries and judges: adding a finding's effect (a cluster of two resonances for a broad line) and
the bounded joint search; the long-τ starts they and re-selection share. Why: docs/loop.md, "Why the loop's moves …"."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy import stats

from ...core.constants import CONFIDENCE_95
from ...core.diagnostics import detectors as det
from ...core.diagnostics.av_signatures import (
    detect_av_signatures,
    fit_gm_to_excess,
    signature_threshold,
    white_allan_variance,
)
from ...core.diagnostics.lines import detect_innovation_hump
from ...core.errors import InputError
from ...core.estimation.em import screen
from ...core.noise.base import Component
from ...core.noise.components import GM, RW, total_allan_variance
from ...core.noise.flicker import BI, PLATEAU, band_for_record
from ...core.noise.modelspec import canonical, nests
from ...core.noise.resonant import MAX_DAMPING, OSC
from ...core.noise.units import random_walk_at_allan_variance
from .rules import av_inside_band, av_rms_z, better, judge, simultaneous_z
from .state import Diagnosis, LoopState, Trial
from .steps import AxisLoop


def added_name(before: list[str], after: list[str], effect: str) -> str:
    """The components a step added, joined by "+" (a GM finding can become an LPF once fitted; a cluster adds two
    OSCs: "OSC+OSC"), else the finding's effect (a regressor or a cleaning)."""
    rest = list(after)
    for name in before:
        if name in rest:
            rest.remove(name)
    return "+".join(rest) if rest else effect


def refit(loop: AxisLoop, diag: Diagnosis, new_state: LoopState) -> Diagnosis:
    """Fit and diagnose ``new_state``; when the warm start lost likelihood against a model it nests, refit with the
    line's power shared (:func:`shared_power_start`) and, on a record fitted exactly (not on the composite
    likelihood, whose fit climbs from a second start of its own), from the estimator's own starts, the best kept."""
    new_diag = loop.diagnose(new_state)
    if new_diag.errors.loglik < diag.errors.loglik and new_state.init is not None:
        shared = shared_power_start(new_state.init, diag.fit.components)
        own = [] if loop.on_composite else [None]
        for init in ([shared] if shared is not None else []) + own:
            new_state.init = init
            retry = loop.diagnose(new_state)
            new_diag = retry if retry.errors.loglik > new_diag.errors.loglik else new_diag
    return new_diag


def shared_power_start(start: list[Component], fitted: list[Component]) -> list[Component] | None:
    """``start`` with each new resonance whose band overlaps a fitted resonance's (centres closer than the wider
    bandwidth) and that resonance both started at σ/√2; None when no new resonance overlaps one."""
    oscs = [(i, c) for i, c in enumerate(start) if isinstance(c, OSC)]
    overlapping = [(i, j) for i, new in oscs if new not in fitted for j, old in oscs
                   if old in fitted and abs(new.frequency - old.frequency) < max(new.bandwidth, old.bandwidth)]
    shared = {k for pair in overlapping for k in pair}
    if not shared:
        return None
    return [replace(c, sigma=c.sigma / math.sqrt(2.0)) if i in shared else c for i, c in enumerate(start)]


def attempt(loop: AxisLoop, diag: Diagnosis, state: LoopState,
            f: det.Finding) -> tuple[list[Trial], Diagnosis | None, LoopState, det.Finding]:
    """Add ``f``'s effect and judge it (:func:`attempt_once`; a broad line's resonance refused or kept in part again
    from :func:`wide_start`, the better kept). Returns (trials, kept diagnosis or None, its state, finding kept for)."""
    outcome = attempt_once(loop, diag, loop.extend(state, f, diag), f)
    kept_partly = outcome[1] is not None and outcome[0][-1].partly
    wide = wide_start(loop, f) if (outcome[1] is None or kept_partly) and broad_resonance(f) else None
    if wide is None:
        return outcome[0], outcome[1], outcome[2], outcome[0][-1].finding
    again = attempt_once(loop, diag, loop.extend(state, wide, diag), wide)
    if outcome[1] is None or (again[1] is not None and better(again[1], outcome[1])):
        superseded = [replace(t, accepted=False, reason=f"{t.reason}; the wide start did better")
                      if t.accepted else t for t in outcome[0]]
        return superseded + again[0], again[1], again[2], again[0][-1].finding
    return outcome[0] + again[0], outcome[1], outcome[2], outcome[0][-1].finding


def attempt_once(loop: AxisLoop, diag: Diagnosis, new_state: LoopState,
                 f: det.Finding) -> tuple[list[Trial], Diagnosis | None, LoopState]:
    """Fit ``new_state`` (``f``'s effect added) and judge it: kept when the BIC improves, the AV is no worse and the
    evidence is gone (or, the BIC refusing it, when it clears the AV band's rejection: :func:`band_cleared`), or via
    :func:`attempt_cluster` or :func:`partly_explained` for a broad line."""
    try:
        new_diag = refit(loop, diag, new_state)
    except (InputError, ValueError, np.linalg.LinAlgError) as exc:
        return [Trial(f, new_state.name(), None, False, f"refit failed: {exc}")], None, new_state
    ok, why = judge(diag, new_diag)
    gone, gone_why = loop.evidence_gone(f, new_diag)
    if ok and not gone and broad_resonance(f):
        return attempt_cluster(loop, diag, new_state, new_diag, f, one_why=f"{why}; {gone_why}")
    if not ok and gone:
        ok, cleared_why = band_cleared(f, diag, new_diag)
        why = f"{why}; {cleared_why}" if ok else why
    ok = ok and gone
    return [Trial(f, new_state.name(), new_diag.errors.bic, ok, f"{why}; {gone_why}")], \
        (new_diag if ok else None), new_state


#: Level of the likelihood-ratio test by which an addition the BIC refuses clears the AV band's rejection
#: (:func:`band_cleared`): χ²_k at 1 − 10⁻³, k the parameters added, 13.8 for a GM. A GM's τ is not identified
#: where its σ is zero (Davies 1987), so the nominal χ² understates the statistic's tail under the null; the level
#: leaves that margin.
BAND_LR_LEVEL = 1e-3


#: Detectors whose findings may clear the AV band's rejection (:func:`band_cleared`): the AV band's own, and the joint
#: search's additions, tried when one-at-a-time is stuck (with the AV outside the band, on that misfit).
BAND_CLEARING_DETECTORS = ("av_band", "joint_search")


def band_cleared(f: det.Finding, before: Diagnosis, after: Diagnosis) -> tuple[bool, str]:
    """Whether ``after`` (``f``'s effect added to ``before``) clears the AV band's rejection of ``before`` though the
    BIC refuses it, and why: ``f`` is the AV band's finding or a joint search's addition
    (:data:`BAND_CLEARING_DETECTORS`), ``before``'s AV lies outside the data's simultaneous band
    (:func:`.rules.av_inside_band`), ``after`` nests ``before`` and its AV lies inside that band with a lower RMS AV
    misfit z, and the likelihood-ratio statistic 2(ℓ_after − ℓ_before) of the nested pair is at least χ²_k's
    (1 − :data:`BAND_LR_LEVEL`) quantile, k the parameters added. The BIC's penalty (k ln n, 27 for a GM on an hour
    at 200 Hz) asks more of a small component on a long record than the two tests together: a GM of τ 20 s beside a
    walk on one hour gains 2Δℓ ≈ 20 and is refused by the BIC while the walk that stands in for it puts the model's
    AV 2.6x above the data's at τ = 360 s. Beyond the papers (docs/loop.md, "The loop's rules" 4)."""
    added = after.fit.n_params - before.fit.n_params
    if (f.detector not in BAND_CLEARING_DETECTORS or added <= 0
            or not nests(after.fit.components, before.fit.components) or av_inside_band(before)
            or not av_inside_band(after) or av_rms_z(after) >= av_rms_z(before)):
        return False, ""
    lr = 2.0 * (after.errors.loglik - before.errors.loglik)
    need = float(stats.chi2.isf(BAND_LR_LEVEL, added))
    if lr < need:
        return False, ""
    return True, (f"the AV band's rejection cleared: the AV inside its band, 2Δℓ = {lr:.1f} ≥ {need:.1f} "
                  f"(χ²_{added} at {1 - BAND_LR_LEVEL:.3g})")


#: BIC decrease that keeps a resonance explaining a broad line in part (Kass & Raftery 1995: > 10 "very strong").
PARTLY_BIC_GAIN = 10.0


def partly_explained(loop: AxisLoop, f: det.Finding, before: Diagnosis, after: Diagnosis) -> tuple[bool, str]:
    """Whether ``after`` explains the broad line ``f`` in part, and why: ``before``'s AV leaves the data's band
    (:func:`.rules.av_inside_band`) and ``after`` lowers the BIC by :data:`PARTLY_BIC_GAIN` or more, the RMS AV misfit
    z and the line's pooled statistic (still above its threshold and half). Beyond the papers."""
    gain = before.errors.bic - after.errors.bic
    if (not broad_resonance(f) or av_inside_band(before) or gain < PARTLY_BIC_GAIN
            or av_rms_z(after) >= av_rms_z(before)):
        return False, ""
    # re-measured last (evidence_gone measured it already; the cheap conditions usually decide first)
    ok = loop.targeted_statistic(f, after) < f.statistic
    return ok, (f"partly explained (BIC {gain:.0f} lower, the AV misfit and the line statistic lower, the AV "
                "outside its band before)" if ok else "")


#: Bandwidth [pooled bins] a refused broad-line resonance is restarted with (docs/loop.md, "Why the loop's moves …").
WIDE_START_POOLED_BINS = 16


def wide_start(loop: AxisLoop, f: det.Finding) -> det.Finding | None:
    """``f`` restarted at the pooled search's scale: a bandwidth [Hz] of :data:`WIDE_START_POOLED_BINS` pooled bins (at
    most half the line's frequency), σ² scaled with it, when its measured bandwidth is narrower; else None."""
    resolution = f.params.get("resolution")
    frequency, bandwidth = f.params.get("frequency"), f.params.get("bandwidth")
    if not resolution or not frequency or bandwidth is None:
        return None
    wide = min(WIDE_START_POOLED_BINS * float(resolution) / (loop.n * loop.dt), 0.5 * float(frequency))
    if wide <= float(bandwidth):
        return None
    # the excess density measured over the narrow band, held over the wide one: σ² grows with the bandwidth
    sigma = float(f.params.get("sigma", 0.0)) * math.sqrt(wide / float(bandwidth))
    return replace(f, params={**f.params, "bandwidth": wide, "sigma": sigma},
                   evidence=f"{f.evidence}; started again {wide:.3g} Hz wide (the pooled search's scale): the "
                            f"measured {float(bandwidth):.3g} Hz was refused")


def broad_resonance(f: det.Finding) -> bool:
    """Whether ``f`` proposes one resonance (OSC) for a line the pooled search found spread over many bins."""
    return f.effect == "OSC" and f.detector == "pooled_periodogram" and not f.members


def attempt_cluster(loop: AxisLoop, diag: Diagnosis, one_state: LoopState, one_diag: Diagnosis, f: det.Finding, *,
                     one_why: str) -> tuple[list[Trial], Diagnosis | None, LoopState]:
    """A broad line one resonance lowered the BIC for but did not explain: the strongest resonance left in the one-OSC
    fit's residuals added beside it, the pair judged as one step (BIC below before and below the one-OSC fit, AV no
    worse, ``f``'s evidence gone). Beyond paper 000, which adds one effect per step."""
    partners = [g for g in one_diag.findings if g.significant and g.effect == "OSC" and not g.members]
    one_trial = Trial(f, one_state.name(), one_diag.errors.bic, False,
                      f"{one_why}" + ("; a cluster of two tried next" if partners else ""))
    if not partners:
        return _one_partly(loop, diag, one_state, one_diag, f, trials=[one_trial])
    second = min(partners, key=lambda g: g.log10_p)
    pair_state = loop.extend(one_state, second, one_diag)
    group = replace(f, members=(f, second),
                    evidence=f"{f.evidence}; a cluster: with a second resonance at "
                             f"{second.params['frequency']:.4g} Hz")
    try:
        pair_diag = refit(loop, one_diag, pair_state)
    except (InputError, ValueError, np.linalg.LinAlgError) as exc:
        return [one_trial, Trial(group, pair_state.name(), None, False, f"refit failed: {exc}")], None, pair_state
    judged, why = judge(diag, pair_diag)
    pays = pair_diag.errors.bic < one_diag.errors.bic
    gone, gone_why = loop.evidence_gone(f, pair_diag)
    why = f"{why}{'' if pays else ' (not better than one resonance)'}; {gone_why}"
    partly, partly_why = (False, "") if gone else partly_explained(loop, f, diag, pair_diag)
    pair_trial = Trial(group, pair_state.name(), pair_diag.errors.bic, judged and pays and (gone or partly),
                       f"{why}; {partly_why}" if partly_why else why, partly=partly)
    if pair_trial.accepted:
        return [one_trial, pair_trial], pair_diag, pair_state
    return _one_partly(loop, diag, one_state, one_diag, f, trials=[one_trial, pair_trial])


def _one_partly(loop: AxisLoop, diag: Diagnosis, one_state: LoopState, one_diag: Diagnosis, f: det.Finding, *,
                trials: list[Trial]) -> tuple[list[Trial], Diagnosis | None, LoopState]:
    """The one-resonance fit kept when it explains the broad line ``f`` in part (:func:`partly_explained`) and no
    cluster did better; its trial (the first of ``trials``) then comes last, as the kept one."""
    partly, partly_why = partly_explained(loop, f, diag, one_diag)
    if not partly:
        return trials, None, one_state
    kept = replace(trials[0], accepted=True, reason=f"{trials[0].reason}; {partly_why}", partly=True)
    return [*trials[1:], kept], one_diag, one_state


def explore(loop: AxisLoop, state: LoopState, diag: Diagnosis,
             trials: list[Trial]) -> tuple[float, LoopState, Diagnosis, det.Finding] | None:
    """The bounded joint search when one-at-a-time is stuck (moves judged by the BIC and do-no-harm rules, or, nesting
    the model, by the band's rejection cleared: :func:`band_cleared`; the best returned): a GM at a tenth of the record
    and BI, the RW restarted small; :func:`hump_resonance`; :func:`flicker_as_gm_and_walk`. On a long record each
    move but the hump's is screened first (:meth:`.AxisLoop.screen_reference`) and refused unrefitted if it cannot
    lower the BIC there. Then the AV signatures at the verdict's band (:func:`band_findings`), each attempted as a
    detector's finding is (:func:`attempt_once`: the BIC, or the band's rejection cleared). Beyond the papers."""
    span = loop.n * loop.dt
    level = long_tau_level(diag)
    proposals = [("GM", {"tau": span / 10.0, "sigma": math.sqrt(level / 0.38)})]
    if "BI" not in state.structure:
        proposals.append(("BI", {"bias_instability": long_tau_flicker(loop, diag).bias_instability}))
    tries: list[tuple[det.Finding, LoopState]] = []
    for effect, params in proposals:
        start = ", ".join(f"{k} {v:.3g}" for k, v in params.items())
        finding = det.Finding.proposed(effect, "joint_search",
                                       f"joint search: {effect} added ({start}), the random walk restarted small",
                                       {**params, "deficit": 1.0})
        tries.append((finding, loop.extend(state, finding, diag)))
    hump = hump_resonance(loop, diag)
    if hump is not None:
        tries.append((hump, loop.extend(state, hump, diag)))
    joint = flicker_as_gm_and_walk(loop, diag)
    if joint is not None:
        gm, walk = (next(c for c in joint if isinstance(c, kind)) for kind in (GM, RW))
        finding = det.Finding.proposed("GM+RW", "joint_search",
                                       f"joint search: flicker noise (BI) replaced by a GM (τ {gm.tau:.3g} s, σ "
                                       f"{gm.sigma:.3g}) and a random walk (K {walk.random_walk:.3g})",
                                       {"tau": gm.tau, "sigma": gm.sigma, "random_walk": walk.random_walk})
        tries.append((finding, state.with_components(joint)))
    best: tuple[float, LoopState, Diagnosis, det.Finding] | None = None
    reference = loop.screen_reference(state, diag)
    for finding, new_state in tries:
        verdict = (screen.screen(reference, new_state.init, loop.statistics)
                   if reference is not None and finding is not hump and new_state.init is not None else None)
        if verdict is not None and not verdict.worth_exact_fit:
            trials.append(Trial(finding, new_state.name(), None, False, f"joint search: {verdict.describe()}"))
            continue
        try:
            new_diag = refit(loop, diag, new_state)
        except (InputError, ValueError, np.linalg.LinAlgError) as exc:
            trials.append(Trial(finding, new_state.name(), None, False, f"joint search: refit failed: {exc}"))
            continue
        ok, why = judge(diag, new_diag)
        if not ok:
            ok, cleared_why = band_cleared(finding, diag, new_diag)
            why = f"{why}; {cleared_why}" if ok else why
        trials.append(Trial(finding, new_state.name(), new_diag.errors.bic, ok, f"joint search: {why}"))
        if ok and (best is None or new_diag.errors.bic < best[0]):
            best = (new_diag.errors.bic, new_state, new_diag, finding)
    for finding in band_findings(loop, diag, state):
        tried, kept, kept_state = attempt_once(loop, diag, loop.extend(state, finding, diag), finding)
        trials += tried
        if kept is not None and (best is None or kept.errors.bic < best[0]):
            best = (kept.errors.bic, kept_state, kept, finding)
    return best


def band_findings(loop: AxisLoop, diag: Diagnosis, state: LoopState) -> list[det.Finding]:
    """The AV signatures (:func:`~imu_noise_id.core.diagnostics.av_signatures.detect_av_signatures`) beyond the data's
    95 % simultaneous band, the one the verdict reads (:func:`.rules.av_inside_band`), where ``diag``'s AV leaves it:
    the addable ones below the detector's own threshold (Bonferroni over every τ at the loop's α, whose findings the
    step's candidates held already); [] when the AV lies inside the band or the band is no wider than that threshold.
    A final AV outside the band is a residual the loop searches on before its verdict says so (docs/loop.md, "The
    loop's rules" 4). Beyond the papers."""
    if av_inside_band(diag):
        return []
    bound = simultaneous_z(diag, CONFIDENCE_95)[2]
    own = signature_threshold(diag.tau.size, loop.alpha)
    if bound >= own:
        return []
    found = detect_av_signatures(diag.tau, diag.av_data, diag.av_ci, diag.av_model,
                                 av_white=white_allan_variance(diag.fit.components, diag.tau, loop.dt),
                                 alpha=loop.alpha, threshold=bound)
    return [f for f in found if f.significant and f.statistic <= own and loop.addable(f, state)]


def hump_resonance(loop: AxisLoop, diag: Diagnosis) -> det.Finding | None:
    """An OSC finding where the innovations hold a significant hump
    (:func:`~imu_noise_id.core.diagnostics.lines.detect_innovation_hump`): f₀ its centre [Hz], B its half-height width
    (≤ ``MAX_DAMPING``·f₀), σ² = 2 Σ (ratio − 1)·S_model(f)·Δf over its bands (two-sided PSDs); None without a hump or
    when it is wider than f₀ (Q < 1). Beyond the papers."""
    hump = detect_innovation_hump(diag.innovations, loop.dt, alpha=loop.alpha)
    if not hump.finding.significant or hump.bandwidth > hump.frequency:
        return None
    width = hump.bandwidth / hump.band_frequency.size
    model_psd = np.sum([c.psd(hump.band_frequency, loop.dt) for c in diag.fit.components], axis=0)
    sigma2 = 2.0 * float(np.sum(np.maximum(hump.ratio - 1.0, 0.0) * model_psd)) * width
    params = {"frequency": hump.frequency, "bandwidth": min(hump.bandwidth, MAX_DAMPING * hump.frequency),
              "sigma": math.sqrt(max(sigma2, 1e-24))}
    return replace(hump.finding, params=params, evidence=f"joint search: {hump.finding.evidence}; a resonance "
                                                         f"added there (σ {params['sigma']:.3g})")


def flicker_as_gm_and_walk(loop: AxisLoop, diag: Diagnosis) -> list[Component] | None:
    """The fitted components with BI replaced by a GM (from the AV the flicker carries short of the last decade,
    :func:`~imu_noise_id.core.diagnostics.av_signatures.fit_gm_to_excess`) and an RW (:func:`long_tau_walk`) when the
    model has BI and neither; None otherwise or when the flicker carries AV at fewer than two τ. Beyond the papers."""
    fitted = list(diag.fit.components)
    names = {c.name for c in fitted}
    if "BI" not in names or "RW" in names or "GM" in names or not diag.tau.size:
        return None
    rest = [c for c in fitted if c.name != "BI"]
    carried = diag.av_data - total_allan_variance(rest, diag.tau, loop.dt)
    use = (carried > 0) & ~_last_decade(diag)
    if int(use.sum()) < 2:
        return None
    tau, sigma = fit_gm_to_excess(diag.tau[use], carried[use])
    return canonical([*rest, GM(tau=max(tau, 2.0 * loop.dt), sigma=sigma), long_tau_walk(diag)])


def _last_decade(diag: Diagnosis) -> np.ndarray:
    """Mask of the diagnosis's τ within the last decade (where the long-τ level is read)."""
    return diag.tau >= 0.1 * diag.tau[-1]


def long_tau_level(diag: Diagnosis) -> float:
    """The data's AV [u²] at long τ (median over the last decade of τ): the level a bias process starts from."""
    return float(np.median(diag.av_data[_last_decade(diag)])) if diag.tau.size else 0.0


def long_tau(diag: Diagnosis) -> float:
    """The τ [s] of :func:`long_tau_level` (median over the last decade of τ)."""
    return float(np.median(diag.tau[_last_decade(diag)]))


def long_tau_walk(diag: Diagnosis) -> RW:
    """The RW whose AV at :func:`long_tau` is :func:`long_tau_level`: a random walk's start in flicker noise's place."""
    return RW(random_walk_at_allan_variance(max(long_tau_level(diag), 1e-30), long_tau(diag)))


def long_tau_flicker(loop: AxisLoop, diag: Diagnosis) -> BI:
    """BI over the record's band (:func:`~imu_noise_id.core.noise.flicker.band_for_record`) whose AV plateau is
    :func:`long_tau_level`: re-selection's swap and the joint search's start."""
    return BI(math.sqrt(max(long_tau_level(diag), 1e-30) / PLATEAU), *band_for_record(loop.n, loop.dt))
