"""Model selection of one axis: every candidate structure fitted, ranked by BIC (ΔBIC, Schwarz weights); intervals
and record-length advice for the winner only."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ...allan import AllanResult
from ...allan.slopes import rises_early, rolloff_end
from ...diagnostics.av_signatures import flicker_level
from ...errors import InputError
from ...noise.components import Component
from ...noise.digital import SensorFilter
from ...noise.modelspec import parse_structure
from ...quality import interpolate_missing
from . import composite, screen, starts, whittle
from .model import FitOptions, NoiseModel, check_signal
from .results import FitResult
from .search import add_intervals

#: Default candidate structures of :func:`select_model` (RR / QN added when the AV suggests them).
DEFAULT_CANDIDATES: tuple[str, ...] = ("WN+RW", "WN+GM", "WN+GM+RW", "WN+2GM")
#: The candidates for the sensor's digital low-pass: with a walk, and with a GM beside it, the filtered twin of
#: WN+GM+RW, so that a record whose filter rules out every unfiltered structure still offers the two readings of its
#: long-τ wander that K's interval must span (docs/analysis.md, "Why K's interval spans the structures the data
#: cannot tell apart").
DLPF_CANDIDATES: tuple[str, ...] = ("WN+DLPF+RW", "WN+DLPF+GM+RW")
#: Candidates also started from an earlier candidate's fit with its walk split into a GM and a smaller walk
#: (:func:`.starts.walk_split`), by the candidate they start from.
SPLIT_FROM = {"WN+DLPF+GM+RW": "WN+DLPF+RW"}


@dataclass
class SelectionResult:
    """Model selection of one axis: the winner and the evidence."""

    best: FitResult
    table: list[dict]  # per candidate: model, loglik, k, aic, bic, delta_bic, weight_bic, delta_aic, error
    fits: dict[str, FitResult]
    #: The winner is still at its composite likelihood's maximiser, without intervals (:func:`select_model` with
    #: ``finish=False``; :func:`finish_winner` finishes it).
    unfinished: bool = False
    #: Per candidate screened out on the statistics of fixed size: the fitted structure it was screened against and
    #: its screen (gain, components fitted there).
    screened: dict[str, tuple[str, screen.Screen]] = field(default_factory=dict)

    def without_data(self) -> SelectionResult:
        """The selection with every fit's record dropped (see :meth:`FitResult.without_data`)."""
        fits = {k: f.without_data() for k, f in self.fits.items()}
        best = next((fits[k] for k, f in self.fits.items() if f is self.best), self.best.without_data())
        return SelectionResult(best, self.table, fits, self.unfinished, self.screened)

    @property
    def best_key(self) -> str:
        """The winner's key in :attr:`fits`."""
        return next(k for k, f in self.fits.items() if f is self.best)


def suggest_candidates(allan: AllanResult) -> list[str]:
    """:data:`DEFAULT_CANDIDATES` plus, from the AV (one column, τ ≤ N·dt/4): RR variants when it rises like τ² at
    long τ, QN variants when it falls like τ⁻² at short τ, WN+BI+RW when flat over a decade above the white-noise
    line (:func:`~imu_noise_id.core.diagnostics.av_signatures.flicker_level`), :data:`DLPF_CANDIDATES` at a low-pass
    roll-off (:func:`~imu_noise_id.core.allan.slopes.rolloff_end`) or a rise within the τ a roll-off reaches
    (:func:`~imu_noise_id.core.allan.slopes.rises_early`); WN+BI+RW last on every record of
    :data:`.screen.MIN_SAMPLES` samples or more, where the screen judges it before any fit: a flicker below the walk
    shows no plateau, and without it the walk's readings are a GM's and a walk's, K read high in a narrow interval
    (docs/analysis.md, "Why K's interval spans the structures the data cannot tell apart")."""
    cands = list(DEFAULT_CANDIDATES)
    keep = allan.m <= starts.MAX_FRACTION * allan.n
    tau, avar = allan.tau[keep], allan.variance[keep, 0]
    if tau.size >= 4 and flicker_level(tau, avar - avar[0] * tau[0] / tau) is not None:
        cands.append("WN+BI+RW")
    if rolloff_end(allan) or rises_early(allan):
        cands += DLPF_CANDIDATES
    if tau.size >= 4:
        slope_hi = np.polyfit(np.log(tau[-3:]), np.log(avar[-3:]), 1)[0]
        slope_lo = np.polyfit(np.log(tau[:3]), np.log(avar[:3]), 1)[0]
        if slope_hi > 1.5:
            cands += ["WN+RW+RR", "WN+GM+RW+RR"]
        if slope_lo < -1.4:
            cands += ["WN+QN+RW", "WN+QN+GM"]
    if "WN+BI+RW" not in cands and allan.n >= screen.MIN_SAMPLES:
        cands.append("WN+BI+RW")
    return cands


def select_model(y: np.ndarray, dt: float, candidates: list[str] | None = None, *, criterion: str = "bic",
                 drift: str | None = "em", options: FitOptions | None = None,
                 allan: AllanResult | None = None,
                 extra_starts: dict[str, list[Component]] | None = None,
                 sensor_filter: SensorFilter | None = None, finish: bool = True) -> SelectionResult:
    """Fit every candidate structure and rank them by ``criterion`` (``'bic'`` or ``'aic'``).

    Parameters
    ----------
    options : fit options; ``uncertainty`` applies to the winner only
    allan : the record's AV (one column): the start of candidates without RR
    extra_starts : a further start per candidate (e.g. its GMWM fit); a candidate of :data:`SPLIT_FROM` is also
        started from the fit it names, its walk split (:func:`.starts.walk_split`)
    sensor_filter : the sensor's known digital low-pass: :data:`DLPF_CANDIDATES` join the default candidates,
        started there
    finish : False leaves a long record's winner at its composite maximiser for :func:`finish_winner`

    From :data:`.screen.MIN_SAMPLES` samples (BIC) a candidate that cannot come within :data:`.screen.MARGIN` of the
        best
    is not fitted (row ``screened``); from :data:`.composite.MIN_SAMPLES` candidates are fitted at the composite
    likelihood's maximiser and scored once exactly (row ``likelihood``), the winner then fitted exactly (beyond the
    papers; docs/em.md, "Searching long records on a likelihood of fixed size"). InputError when no candidate fits.
    """
    if criterion not in ("bic", "aic"):
        raise InputError(f"criterion must be 'bic' or 'aic', got {criterion!r}")
    options = options or FitOptions()
    y = check_signal(y, dt)
    # The AV the starting values need, keyed by "the structure has RR" (then: of the detrended record).
    allans = {False: allan if allan is not None else starts.allan_of(interpolate_missing(y), dt), True: None}
    periodograms: dict[bool, whittle.BandedPeriodogram | None] = {False: None, True: None}  # the same, computed once
    cands = list(candidates) if candidates else suggest_candidates(allans[False])
    if sensor_filter is not None and not candidates:
        cands += [spec for spec in DLPF_CANDIDATES if spec not in cands]
    fits: dict[str, FitResult] = {}
    errors: dict[str, str] = {}
    search = replace(options, uncertainty=False)
    best_key: str | None = None
    best_model: NoiseModel | None = None
    screening = criterion == "bic" and y.size >= screen.MIN_SAMPLES
    statistics = screen.Statistics.of(interpolate_missing(y), dt) if screening else None
    if statistics is not None:  # its periodogram is that of the record the candidates without RR start from
        periodograms[False] = statistics.periodogram
    composite_stats = composite.CompositeStatistics.of(y, dt) if y.size >= composite.MIN_SAMPLES else None
    reference: screen.Reference | None = None
    screened: dict[str, tuple[str, screen.Screen]] = {}
    for spec in cands:
        try:
            has_rr = "RR" in parse_structure(spec)
            further = [extra_starts[spec]] if extra_starts and spec in extra_starts else []
            if SPLIT_FROM.get(spec) in fits:
                split = starts.walk_split(list(fits[SPLIT_FROM[spec]].components), y.size * dt)
                further += [split] if split is not None else []
            model = NoiseModel(y, dt, spec, drift=drift, allan=allans[has_rr], periodogram=periodograms[has_rr],
                               starts=further or None, sensor_filter=sensor_filter)
            if reference is not None and statistics is not None:
                first, *others = model.starting_values(search.n_starts, True)
                verdict = screen.screen(reference, first, statistics, others)
                if not verdict.worth_exact_fit:
                    screened[spec] = (best_key, verdict)
                    allans[has_rr], periodograms[has_rr] = model.allan, model.banded_periodogram()
                    continue
            if composite_stats is not None:
                fit = composite.fit_model(model, model.starting_values(search.n_starts, search.spectral_init),
                                          composite_stats)
            else:
                fit = model.fit(options=search)
            allans[has_rr] = model.allan
            if search.spectral_init:
                periodograms[has_rr] = model.banded_periodogram()
        except InputError as exc:
            errors[spec] = str(exc)
            continue
        # Only the current best keeps its record (N floats per array): memory stays bounded on long records.
        if best_key is None or getattr(fit, criterion) < getattr(fits[best_key], criterion):
            if best_key is not None:
                fits[best_key] = fits[best_key].without_data()
            best_key, best_model = spec, model
            if statistics is not None:
                reference = screen.Reference.fit(list(fit.components), statistics)
        else:
            fit = fit.without_data()
        fits[spec] = fit
    if best_key is None or best_model is None:
        raise InputError("no candidate model could be fitted: " + "; ".join(f"{k}: {v}" for k, v in errors.items()))
    unfinished = composite_stats is not None and not finish
    if composite_stats is not None and finish:
        fits[best_key] = _finished(best_model, fits[best_key], options)
    elif options.uncertainty and not unfinished:  # before the table: searched again, the likelihood can only rise
        fits[best_key] = add_intervals(best_model, fits[best_key], options)
    others = [{"model": spec, "screened": screened[spec][1].describe(), "delta_bic_screen": screened[spec][1].delta_bic}
              if spec in screened else {"model": spec, "error": errors[spec]}
              for spec in cands if spec not in fits]
    at_composite = ({k for k in fits if k != best_key or unfinished} if composite_stats is not None else set())
    return SelectionResult(fits[best_key], _table(fits, others, criterion, at_composite), fits, unfinished, screened)


#: A selection table row's ``likelihood`` when its fit is the composite likelihood's maximiser.
AT_COMPOSITE_MAXIMUM = "exact, at the composite likelihood's maximiser"


def _finished(model: NoiseModel, fit: FitResult, options: FitOptions) -> FitResult:
    """``fit`` refitted exactly from its composite maximiser (kept if better), with intervals if asked."""
    exact = model.fit(list(fit.components), replace(options, uncertainty=False))
    fit = exact if exact.loglik > fit.loglik else fit
    return add_intervals(model, fit, options) if options.uncertainty else fit


def _table(fits: dict[str, FitResult], others: list[dict], criterion: str, at_composite: set[str]) -> list[dict]:
    """Rows per fit (likelihood, criteria, differences to the best, BIC weight; ``likelihood``
    :data:`AT_COMPOSITE_MAXIMUM` for ``at_composite``), then ``others``, sorted by ``criterion``."""
    bic_min = min(f.bic for f in fits.values())
    aic_min = min(f.aic for f in fits.values())
    wsum = sum(math.exp(-0.5 * (f.bic - bic_min)) for f in fits.values())
    rows = []
    for key, f in fits.items():
        rows.append({"model": f.model, "loglik": f.loglik, "k": f.n_params, "aic": f.aic, "bic": f.bic,
                     "delta_bic": f.bic - bic_min, "delta_aic": f.aic - aic_min,
                     "weight_bic": math.exp(-0.5 * (f.bic - bic_min)) / wsum, "converged": f.converged})
        if key in at_composite:
            rows[-1]["likelihood"] = AT_COMPOSITE_MAXIMUM
    return sorted(rows + others, key=lambda r: r.get(criterion, math.inf))


def finish_winner(selection: SelectionResult, model: NoiseModel, options: FitOptions,
                  criterion: str = "bic") -> SelectionResult:
    """A ``finish=False`` selection finished: its winner fitted on ``model``'s exact likelihood from the composite
    maximiser (intervals when ``options.uncertainty``), the table ranked again; unchanged when finished."""
    if not selection.unfinished:
        return selection
    key = selection.best_key
    fits = {**selection.fits, key: _finished(model, selection.best, options)}
    others = [row for row in selection.table if "loglik" not in row]
    return SelectionResult(fits[key], _table(fits, others, criterion, set(fits) - {key}), fits,
                           screened=selection.screened)
