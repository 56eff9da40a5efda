"""Running the closed loop on one axis or on an IMU recording's axes (rules: :mod:`imu_noise_id.pipelines.loop`)."""

from __future__ import annotations

import copy
from dataclasses import replace
from typing import Any

import numpy as np

from ...core.axes import AXES, ImuSeries, ScalarSeries
from ...core.diagnostics import detectors as det
from ...core.errors import InputError
from ...core.estimation.em.relabel import with_uncertainty
from ...core.estimation.em.results import FitResult
from ...core.noise.modelspec import parse_structure
from .reselection import reselect, swap_start_filter
from .rules import (
    PRACTICAL_AV_ERROR,
    av_inside_band,
    max_relative_av_error,
    practically_negligible,
    with_av_misfit,
)
from .state import Diagnosis, LoopResult, LoopState, LoopStep, Trial
from .steps import AxisLoop
from .trials import added_name, attempt, explore

#: Effects the loop adds at most per axis (docs/loop.md, "Why the loop's moves are built as they are").
MAX_STEPS = 14


def run_closed_loop(
    y: np.ndarray,
    dt: float,
    start: str | FitResult,
    *,
    temperature: np.ndarray | None = None,
    max_steps: int = MAX_STEPS,
    max_candidates: int = 3,
    alpha: float = det.ALPHA,
    lags: int = 20,
    outliers: str = "impute",
    axis: str | None = None,
    intervals: bool = False,
) -> LoopResult:
    """Run the closed loop on one axis (rules: :mod:`imu_noise_id.pipelines.loop`).

    Parameters
    ----------
    y, dt : (N,) array, float
        Samples of one axis [u] (rad/s or m/s²), NaN = missing; their sampling period [s].
    start : str or FitResult
        Starting structure (``"WN+RW"``), or a fit of this very record (kept as step 0, not refitted).
    temperature : (N,) array, optional
        Sensor temperature [°C] at the sample times (:func:`align_temperature`); enables ``TEMP``.
    max_steps, max_candidates, alpha, lags : int, int, float, int
        Effects added at most; candidates refitted per step; level of every detector; Ljung–Box lags.
    outliers, axis : {"impute", "missing"}, str or None
        How flagged outliers are removed; the axis's name, for the report.
    intervals : bool
        Give the final fit its 95 % intervals (:func:`final_intervals`) when an effect was added.

    Raises
    ------
    InputError
        Not 1-D, inf, fewer than 1000 finite samples, temperature misaligned or not finite.
    """
    y = np.asarray(y, dtype=float)
    if y.ndim != 1:
        raise InputError(f"closed loop: samples of one axis expected (1-D), got shape {y.shape}")
    if np.any(np.isinf(y)):
        raise InputError("closed loop: samples contain inf")
    if int(np.isfinite(y).sum()) < 1000:
        raise InputError(f"closed loop: need at least 1000 finite samples, got {int(np.isfinite(y).sum())}")
    if not (np.isfinite(dt) and dt > 0):
        raise InputError(f"closed loop: sampling period must be > 0, got {dt!r}")
    if temperature is not None:
        temperature = np.asarray(temperature, dtype=float)
        if temperature.shape != y.shape or not np.all(np.isfinite(temperature)):
            raise InputError("closed loop: temperature must be finite and aligned with the samples "
                             "(use align_temperature)")
        if np.ptp(temperature) <= 0:
            temperature = None
    if max_steps < 0 or max_candidates < 1:
        raise InputError("closed loop: max_steps must be >= 0 and max_candidates >= 1")
    if outliers not in ("impute", "missing"):
        raise InputError(f"closed loop: outliers must be 'impute' or 'missing', got {outliers!r}")
    loop = AxisLoop(y, float(dt), temperature, alpha=alpha, lags=lags, outliers=outliers)
    start_fit = start if isinstance(start, FitResult) else None
    if start_fit is not None and (start_fit.record is None or start_fit.n != int(np.isfinite(y).sum())):
        raise InputError("closed loop: the starting fit must be a fit of this record that keeps its data")
    state = LoopState(structure=parse_structure(start_fit.model if start_fit is not None else start))
    if start_fit is not None and loop.on_composite:
        # the moves are judged against the start fitted as they are (on the composite likelihood)
        state.init = list(start_fit.components)
        start_fit = None
    diag = loop.diagnose(state, start_fit)
    steps = [LoopStep(0, state.name(), None, None, None, state, diag, [])]
    swapped = swap_start_filter(loop, state, diag) if max_steps > 0 else None
    if swapped is not None:
        trial = swapped[0]
        steps[0].trials.append(trial)
        if trial.accepted:
            _, state, diag = swapped
            steps.append(LoopStep(1, state.name(), "OSC", trial.finding.evidence, trial.finding, state, diag, [],
                                  ("LPF (for OSC)",)))
    verdict, passed = "", False
    explored = False
    while True:
        cands = loop.candidates(diag, state)
        if len(steps) > max_steps:
            passed = not any(f.significant for f in diag.findings)
            verdict = ("residuals pass: no detector fires at its level" if passed else
                       f"stopped after {max_steps} added effects; residual evidence remains")
            break
        trials: list[Trial] = []
        best: tuple[float, LoopState, Diagnosis, det.Finding] | None = None
        for f in cands[:max_candidates]:
            tried, kept, kept_state, kept_for = attempt(loop, diag, state, f)
            trials += tried
            if kept is not None and (best is None or kept.errors.bic < best[0]):
                # the finding it was kept for: a cluster's group (both resonances), a wide start's finding
                best = (kept.errors.bic, kept_state, kept, kept_for)
        if best is None and not explored:
            # One-at-a-time is stuck (no detector fires, or nothing it proposed was kept): the bounded joint search.
            explored = True
            best = explore(loop, state, diag, trials)
        if best is None:
            steps[-1].trials += trials
            if not cands:
                left = sorted({f.effect for f in diag.findings if f.significant})
                passed = not left
                verdict = ("residuals pass: no detector fires at its level" if passed else
                           f"nothing more can be added: evidence for {', '.join(left)} remains, but these effects "
                           "are already in the model")
            else:
                verdict = "nothing improves: no candidate lowered the BIC with its evidence gone and the AV no worse"
            break
        previous, before = list(state.structure), list(diag.fit.components)
        _, state, diag, f = best
        steps[-1].trials += trials
        added = added_name(previous, state.structure, f.effect)
        # what the step itself replaced (the joint search's flicker noise for a GM and a random walk)
        replaced = [f"{name} (for {added})" for name in added_name(state.structure, previous, "").split("+") if name]
        state, diag, dropped, drop_trials = reselect(loop, state, diag, added=added, before=before)
        steps.append(LoopStep(len(steps), state.name(), added, f.evidence, f, state, diag, drop_trials,
                              tuple(replaced + dropped)))
    note, finish_gain = "", None
    if loop.on_composite and len(steps) > 1:
        composite_loglik = diag.fit.loglik
        steps[-1], note = exact_finish(loop, steps[-1])
        diag = steps[-1].diagnosis
        finish_gain = float(diag.fit.loglik - composite_loglik)
    if intervals and len(steps) > 1:
        steps[-1], interval_note = final_intervals(loop, steps[-1])
        note = "; ".join(filter(None, [note, interval_note]))
        diag = steps[-1].diagnosis
    inside, worst = av_inside_band(diag), max_relative_av_error(diag)
    if not passed and practically_negligible(diag):
        passed = True
        left = ", ".join(sorted({f.effect for f in diag.findings if f.significant}))
        note = "; ".join(filter(None, [
            note, f"residual evidence remains ({left}) but is of no practical significance: at every τ the model's "
            f"AV lies inside the data's 95 % band or within {100 * PRACTICAL_AV_ERROR:.0f} % of the data's AV "
            f"(largest relative AV error {100 * worst:.0f} %)"]))
    passed, verdict = with_av_misfit(passed, verdict, diag)
    remaining = [f for f in diag.findings if f.significant]
    return LoopResult(axis=axis, dt=float(dt), n=y.size, steps=steps, passed=passed, verdict=verdict,
                      remaining=remaining, av_inside_band=inside, max_rel_av_error=worst, note=note,
                      finish_gain=finish_gain)


def exact_finish(loop: AxisLoop, step: LoopStep) -> tuple[LoopStep, str]:
    """``step`` (fitted on the composite likelihood, :meth:`.AxisLoop.fit_state`) refitted on the exact one and
    diagnosed again, and a note: "" unless the refit failed or did not gain (``step`` then returned as it is) or
    stopped at its budget (:attr:`~imu_noise_id.core.estimation.em.results.FitResult.budget_stop`)."""
    state = step.state.with_components(list(step.diagnosis.fit.components))
    try:
        diag = loop.diagnose(state, exact=True)
    except (ValueError, np.linalg.LinAlgError) as exc:  # InputError is a ValueError
        return step, f"the final fit is the composite likelihood's maximiser: its exact refit failed ({exc})"
    if diag.fit.loglik <= step.diagnosis.fit.loglik:
        return step, ""
    return replace(step, state=state, diagnosis=diag), diag.fit.budget_stop_text() or ""


def final_intervals(loop: AxisLoop, step: LoopStep) -> tuple[LoopStep, str]:
    """``step`` with its fit's 95 % intervals (:func:`~imu_noise_id.core.estimation.em.relabel.with_uncertainty`) and a
    note ("" unless refitted). Beyond the papers: where the intervals' search met a higher likelihood
    (``short_of_maximum``) the structure is refitted from there and diagnosed once; the step is then the refit's."""
    fit = with_uncertainty(step.diagnosis.fit)
    as_it_is = replace(step, diagnosis=replace(step.diagnosis, fit=fit)), ""
    if fit.short_of_maximum is None or fit.better_start is None:
        return as_it_is
    state = step.state.with_components(fit.better_start)
    try:
        diag = loop.diagnose(state, exact=True)
    except (ValueError, np.linalg.LinAlgError):  # InputError is a ValueError
        return as_it_is
    gain = diag.fit.loglik - step.diagnosis.fit.loglik
    if gain <= 0.0:
        return as_it_is
    refit = with_uncertainty(diag.fit)
    return (replace(step, state=state, diagnosis=replace(diag, fit=refit)),
            f"the final fit was fitted again from where its intervals' search met a higher likelihood "
            f"(log-likelihood +{gain:.3g})")


def align_temperature(t_samples: np.ndarray, t_temperature: np.ndarray, temperature: np.ndarray) -> np.ndarray:
    """Temperature [°C] at the sample times ``t_samples`` [s], linearly interpolated (held beyond its ends); InputError
    for fewer than two samples, non-finite values or non-increasing times."""
    t_temperature = np.asarray(t_temperature, dtype=float)
    temperature = np.asarray(temperature, dtype=float)
    if t_temperature.size < 2 or t_temperature.shape != temperature.shape:
        raise InputError("temperature topic: need at least two samples with stamps")
    if not (np.all(np.isfinite(temperature)) and np.all(np.isfinite(t_temperature))):
        raise InputError("temperature topic holds NaN/inf values")
    if np.any(np.diff(t_temperature) <= 0):
        raise InputError("temperature topic: stamps are not strictly increasing")
    return np.interp(np.asarray(t_samples, dtype=float), t_temperature, temperature)


class ImuLoop:
    """The closed loop on the axes of the recording ``imu`` at its own period ``imu.dt``, one axis at a time; the bag's
    ``temperature`` topic (enables ``TEMP``) aligned once; ``loop_kwargs`` passed to :func:`run_closed_loop`."""

    def __init__(self, imu: ImuSeries, temperature: ScalarSeries | None = None, **loop_kwargs: Any) -> None:
        self.imu = imu
        self.dt = imu.dt
        self.temperature = None
        if temperature is not None:
            self.temperature = align_temperature(imu.t, temperature.t, temperature.value)
        self.loop_kwargs = loop_kwargs

    def on(self, imu: ImuSeries) -> ImuLoop:
        """This loop (settings, aligned temperature) over ``imu``, the same recording held elsewhere (e.g. mapped)."""
        loop = copy.copy(self)
        loop.imu = imu
        return loop

    def run(self, axis: str, start: str | FitResult) -> LoopResult:
        """The loop on ``axis`` from ``start``: a structure, or a fit of the axis (then step 0 as it is)."""
        return run_closed_loop(self.imu.axis(axis), self.dt, start, temperature=self.temperature, axis=axis,
                               **self.loop_kwargs)


def run_closed_loop_imu(imu: ImuSeries, start: str | dict[str, str | FitResult], *,
                        temperature: ScalarSeries | None = None, axes: tuple[str, ...] = AXES,
                        **loop_kwargs: Any) -> dict[str, LoopResult]:
    """:class:`ImuLoop` on several axes from one starting structure, or per axis (structures or fits)."""
    loop = ImuLoop(imu, temperature, **loop_kwargs)
    return {axis: loop.run(axis, start[axis] if isinstance(start, dict) else start) for axis in axes}
