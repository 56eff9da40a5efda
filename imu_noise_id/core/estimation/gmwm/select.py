"""GMWM model selection by the wavelet information criterion (Guerrier, Stebler, Skaloud & Victoria-Feser 2015;
gmwm's ``rank.models``): WIC = J(θ̃_k) + 2·tr(Ω A H⁻¹ Aᵀ Ω V) under one weight Ω for all candidates, V(θ̂) of the
structure nesting them (:func:`full_structure`; if it fails, the candidate with the best J-test p). Candidates from
the EM selection's :func:`suggest_candidates`; intervals for the winner only. Beyond the paper: WICs within
:data:`WIC_TIE` tie, with each tied fit's :func:`walk_look_alike`; the fewest parameters win (docs/gmwm.md, "Why:
model selection by WIC"); the record's spectral lines offered to the winner (:mod:`.lines`)."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

from ...allan import AllanResult
from ...diagnostics.lines import LineShape
from ...errors import InputError
from ...noise.components import GM, Component
from ...noise.modelspec import parameter_labels, parse_structure, structure_name
from ...wavelet.variance import WaveletVariance
from ..em.selection import suggest_candidates
from . import engine as eng
from .fit import Estimate, GmwmFit, GmwmOptions, dress, estimate_structure, prepare
from .lines import LineTrial, offer_lines

#: Relative WIC difference within which two candidates are one tie (:func:`select_gmwm`).
WIC_TIE = 1e-6


@dataclass
class GmwmSelection:
    """WIC ranking of one axis: winner, table (best first; model, k, wic, delta_wic, j_statistic, dof, p_value, or
    model and error; each line offered after them: model, k, delta_wic, line), every fit, and the reference structure
    of the weight."""

    best: GmwmFit
    table: list[dict]
    fits: dict[str, GmwmFit]
    reference: str
    line_trials: tuple[LineTrial, ...] = ()

    def lines_left_out(self) -> list[str]:
        """Why each significant line of the record that is not in the winner was left out, in words."""
        return [f"a spectral line at {t.line.frequency:.4g} Hz is not in the GMWM model ({t.error}): N and K may "
                "carry its power" for t in self.line_trials if t.error]


def full_structure(candidates: list[str]) -> str:
    """The smallest structure nesting every candidate: per component type the largest count any candidate has."""
    most: Counter[str] = Counter()
    for spec in candidates:
        for name, count in Counter(parse_structure(spec)).items():
            most[name] = max(most[name], count)
    return structure_name([n for n, c in most.items() for _ in range(c)])


def walk_look_alike(components: list[Component], span_s: float) -> str:
    """The structure ``components`` are over a record of ``span_s`` [s]: GMs with τ > span as one random walk."""
    names = [c.name for c in components if not (isinstance(c, GM) and c.tau > span_s)]
    if len(names) < len(components) and "RW" not in names:
        names.append("RW")
    return structure_name(names)


def select_gmwm(y, dt: float, candidates: list[str] | None = None, *, options: GmwmOptions | None = None,
                allan: AllanResult | None = None, wv: WaveletVariance | None = None,
                slope: float | None = None, lines: tuple[LineShape, ...] = ()) -> GmwmSelection:
    """Fit every candidate by GMWM and rank them by WIC. ``allan``: the record's AV for the candidate list; ``wv``
    and ``slope``: the record's WV and least-squares slope [u/s] (``y`` then unused); ``lines``: the record's spectral
    lines (:func:`.lines.record_lines`), each offered to the winner as an OSC (:func:`.lines.offer_lines`)."""
    options = options or GmwmOptions()
    if wv is None:
        wv, slope = prepare(y, dt, options)
    cands = list(candidates) if candidates else suggest_candidates(allan if allan is not None else wv.as_allan())
    ests: dict[str, Estimate] = {}
    errors: dict[str, str] = {}
    for spec in cands:
        try:
            ests[spec] = estimate_structure(wv, spec, options=options)
        except InputError as exc:
            errors[spec] = str(exc)
    if not ests:
        raise InputError("no candidate model could be fitted: " + "; ".join(f"{k}: {v}" for k, v in errors.items()))
    reference = full_structure(cands)
    try:
        ref = ests.get(reference) or estimate_structure(wv, reference, options=options)
    except InputError:
        reference, ref = max(ests.items(), key=lambda kv: kv[1].inference.p_value)
    runs = [eng.Moments(wv)]
    weights = eng.Weights.at(runs, ref.components)
    wic = {spec: est.wic(weights) for spec, est in ests.items()}
    low = min(wic.values())
    tied = [spec for spec in wic if wic[spec] - low <= WIC_TIE * max(1.0, abs(low))]
    alike = {walk_look_alike(ests[spec].components, wv.n * wv.dt) for spec in tied}
    tied += [spec for spec in wic if spec not in tied and structure_name(parse_structure(spec)) in alike]
    best_spec = min(tied, key=lambda spec: len(parameter_labels(ests[spec].components)))
    winner = best_spec
    final, trials = offer_lines(wv, ests[best_spec], list(lines), options=options)
    if final is not ests[best_spec]:
        best_spec = structure_name([c.name for c in final.components])
        ests[best_spec] = final
    fits = {spec: dress(est, n=wv.n, dt=wv.dt, options=options, slope=slope,
                        uncertainty=spec == best_spec) for spec, est in ests.items()}
    table = [{"model": fits[s].model, "k": fits[s].n_params, "wic": wic[s], "delta_wic": wic[s] - low,
              "j_statistic": fits[s].j_statistic, "dof": fits[s].dof, "p_value": fits[s].p_value} for s in wic]
    table.sort(key=lambda r: (r["model"] != fits[winner].model, r["wic"]))
    table += [{"model": s, "error": e} for s, e in errors.items()]
    table += [trial.row() for trial in trials]
    return GmwmSelection(fits[best_spec], table, fits, reference, tuple(trials))
