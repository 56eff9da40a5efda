"""The self-contained ``report.html`` of an analysis (base64 PNG figures) from the ``AnalysisResult``: the data, the
numbers users paste, Allan panels, model selection, record length, GMWM, loop steps and overbound; its sections are
independent tasks (:func:`report_sections`), joined by :func:`assemble_report`."""

from __future__ import annotations

import html
import math
from collections.abc import Callable
from functools import partial

import numpy as np

from ..core.allan.slopes import SlopeComponent
from ..core.axes import AXES, UNITS
from ..pipelines.analyze import AnalysisResult
from ..pipelines.analyze.numbers import UPPER_BOUND_METHODS
from .html import LOOP_INTRO, STYLE, fmt, img_tag, loop_axis_section
from .plots_model import allan_panel_png


def _ci(value: float | None, ci: tuple[float, float]) -> str:
    return "n/a" if value is None else f"{fmt(value)} [{fmt(ci[0])}, {fmt(ci[1])}]"


def _pasted(value: float | None, ci: tuple[float, float], method: str) -> str:
    """:func:`_ci`, with '< ' before an upper bound (:data:`~..pipelines.analyze.numbers.UPPER_BOUND_METHODS`), as
    the console prints it."""
    return f"< {_ci(value, ci)}" if value is not None and method in UPPER_BOUND_METHODS else _ci(value, ci)


def _data_section(result: AnalysisResult, meta: dict) -> str:
    s = result.static
    rate = s.period.describe() if s.period is not None else f"{s.rate_hz:.6g} Hz"
    rows = [("source", meta.get("source", "?")), ("topic", s.topic), ("samples per axis", f"{s.n}"),
            ("duration", f"{s.duration_s:.1f} s ({s.duration_s / 3600:.2f} h)"), ("rate", rate),
            ("command", meta.get("command", "analyze")), ("model", meta.get("model", "auto"))]
    table = "".join(f"<tr><th class=l>{html.escape(k)}</th><td class=l>{html.escape(str(v))}</td></tr>"
                    for k, v in rows)
    warnings = s.warnings + result.warnings
    items = "".join(f"<li>{html.escape(w)}</li>" for w in warnings) or "<li>none</li>"
    alarm = ""
    if s.period is not None and not s.period.trusted:
        alarm = "".join(f"<p class=warn><b>Sample rate not taken from the stamps at face value:</b> "
                        f"{html.escape(w)}</p>" for w in s.period.warnings)
    return (f"<h2 id=data>Data</h2>{alarm}<table>{table}</table>"
            f"<p>Warnings, repairs and the static check:</p><ul>{items}</ul>")


def _allan_cell(reading: SlopeComponent, disagrees: bool) -> str:
    """A table cell with an Allan-slope reading: '&lt;' before an upper bound; marked '≠' (class warn), with its
    interval, where it does not overlap the pasted number's."""
    text = f"{'&lt; ' if reading.method == 'upper_bound' else ''}{fmt(reading.value)}"
    if not disagrees:
        return f"<td>{text}</td>"
    return f"<td class=warn>≠ {text} <span class=small>[{fmt(reading.ci[0])}, {fmt(reading.ci[1])}]</span></td>"


def _numbers_section(result: AnalysisResult) -> str:
    head = ("<tr><th class=l>axis</th><th class=l>final model (source)</th><th>N [u/√Hz], 95 %</th>"
            "<th>K [u/s/√Hz], 95 %</th><th>bias instability B [u], 95 %</th><th>per-sample σ [u]</th>"
            "<th>Allan N</th><th>Allan K</th><th>Allan B</th></tr>")
    rows = []
    numbers = result.numbers  # what imu.yaml pastes (None: only the final models are known)
    for axis, f in result.finals.items():
        slopes = result.static.slopes[axis]
        b = f.bias_instability
        pasted = numbers.axis(axis) if numbers is not None and axis in AXES else None
        n, k = (pasted.noise_density, pasted.random_walk) if pasted is not None else (f.noise_density, f.random_walk)
        k_text = (_pasted(k.value, k.ci95, k.method) if k.value is not None
                  else "not identifiable (no RW in the final model)")
        if k.method.startswith("allan"):
            k_text = f"{k_text} ({k.method}: the final model has no random walk)"
        if f.random_walk_above_bound:
            k_text = f"{k_text} — above the long-τ AV's bound {fmt(f.random_walk_bound.value)}"
        disagree = pasted.allan_disagreements() if pasted is not None else ()
        rows.append(
            f"<tr><td class=l>{axis} [{UNITS.get(axis, 'u')}]</td><td class=l>{html.escape(f.model)} "
            f"<span class=small>({html.escape(f.source)})</span></td>"
            f"<td>{html.escape(_pasted(n.value, n.ci95, n.method))}</td>"
            f"<td{' class=warn' if f.random_walk_above_bound else ''}>{html.escape(k_text)}</td>"
            f"<td>{html.escape(_pasted(b.value, b.ci95, b.method()))} <span class=small>at τ = "
            f"{fmt(b.tau_at_minimum, '.3g')} s</span></td><td>{fmt(f.noise_stddev_per_sample)}</td>"
            f"{_allan_cell(slopes.noise_density, 'noise_density' in disagree)}"
            f"{_allan_cell(slopes.random_walk, 'random_walk' in disagree)}"
            f"<td>{'' if f.bias_instability_allan.reached else '&lt; '}{fmt(f.bias_instability_allan.value)}</td>"
            "</tr>")
    note = ("<p class=small>N is the passband white-noise density √(N_WN² + N_LPF² + N_MA² + N_OSC²), each at its "
            "zero-frequency density as sampled (N_OSC: an OSC of short memory, five samples or 50 ms, white below its "
            "corner); "
            "narrow oscillations (OSC), sinusoids, GMs, "
            "flicker noise (BI), temperature and the shape of the sensor's own filter are kept out of N and K. "
            "'&lt;' before N or K: an upper bound the record gives where it does not resolve the value, its "
            "interval [0, value]. Where the final model has no random walk, imu.yaml gives the Allan-slope reading "
            "(marked). "
            "An Allan-slope reading marked ≠ has a 95 % interval that does not overlap the pasted number's: the slope "
            "line takes the Allan variance over its τ range as white noise and a walk alone, while the final model is "
            "fitted to the whole record (a walk read through a GM's bump reads high). "
            "B = the flicker component's bias instability when the model has one, else min of the model's Allan "
            "deviation without vibration lines / 0.664 ('&lt;': still falling at a tenth of the record, an upper "
            "bound, its interval [0, B]). The Kalibr keys of imu.yaml are the max of N and K over each sensor's "
            "three axes. A K above the long-τ AV's bound (the largest random walk the data's AV at τ beyond a tenth "
            "of the record supports, 95 % simultaneous) is flagged: a bounded wander fits the record as well, and "
            "only a longer record tells them apart.</p>")
    return f"<h2 id=numbers>The numbers to paste</h2><table>{head}{''.join(rows)}</table>{note}"


def _overbound_section(result: AnalysisResult) -> str:
    if not result.overbounds:
        return ""
    first = next(iter(result.overbounds.values()))
    head = ("<tr><th class=l>axis</th><th>N [u/√Hz]</th><th>× over N</th><th>K [u/s/√Hz]</th><th>× over K</th>"
            "<th>touches the bound at τ [s]</th><th class=l>inflated over</th></tr>")
    rows = "".join(
        f"<tr><td class=l>{axis} [{UNITS.get(axis, 'u')}]</td><td>{fmt(o.noise_density)}</td>"
        f"<td>{fmt(o.inflation_noise_density, '.3g')}{' (fitted)' if o.bound.at_floor[0] else ''}</td>"
        f"<td>{fmt(o.random_walk)}</td><td>{fmt(o.inflation_random_walk, '.3g')}"
        f"{' (fitted)' if o.bound.at_floor[1] else ''}</td>"
        f"<td>{', '.join(fmt(t, '.3g') for t in o.bound.binding_tau) or '—'}</td>"
        f"<td class=l>{html.escape(o.reference_source)}</td></tr>" for axis, o in result.overbounds.items())
    note = (f"<p>The honest version of “inflate the noise ×10”: for τ from {fmt(first.tau_range[0], '.3g')} s to "
            f"{fmt(first.tau_range[1], '.3g')} s (the sampling period to --horizon {fmt(first.horizon_s, 'g')} s), "
            f"the smallest white noise + random walk (Kalibr's N and K) whose Allan variance lies above "
            f"{html.escape(first.covers.split(' (')[0])} at every τ of the range, and not below the fitted values "
            "(least mean ratio of its AV to the bound over the τ grid). The factors say how much a WN+RW filter's "
            "N and K must be raised to cover what this IMU does over that range; the orange line in each Allan "
            "panel is this overbound. imu.yaml holds it under <code>overbound:</code>; "
            "<code>imu-noise-id export DIR --overbound</code> writes the filters' files from it.</p>")
    return f"<h2 id=overbound>Overbound (the honest ×10)</h2>{note}<table>{head}{rows}</table>"


def _allan_panel(result: AnalysisResult, axis: str) -> str:
    """The Allan panel of ``axis`` (data, band, final model, slopes, overbound) as an embedded PNG."""
    s = result.static
    f = result.finals[axis]
    j = s.axes.index(axis)
    lines = {c.name: (c.slope, c.coefficient) for c in s.slopes[axis].components()}
    ob = result.overbounds.get(axis)
    overbound = None
    if ob is not None:
        t = np.exp(np.linspace(np.log(ob.tau_range[0]), np.log(ob.tau_range[1]), 100))
        overbound = (t, ob.allan_variance(t, s.dt), f"overbound WN+RW (N ×{ob.inflation_noise_density:.3g}, "
                                                    f"K ×{ob.inflation_random_walk:.3g})")
    png = allan_panel_png(s.allan.tau, s.allan.variance[:, j], (s.allan.ci_low[:, j], s.allan.ci_high[:, j]),
                          f.fit, band=result.bands.get(axis), lines=lines, unit=UNITS.get(axis, "u"),
                          title=f"{axis}: final model {f.model}", overbound=overbound)
    return img_tag(png, f"Allan deviation of {axis}")


def _selection_section(result: AnalysisResult) -> str:
    out = ["<h2 id=selection>Model selection and recording length</h2>"]
    for axis, m in result.models.items():
        if m.selection is not None:
            nan = float("nan")
            rows = "".join(
                f"<tr><td class=l>{html.escape(str(r.get('model')))}</td><td>{fmt(r.get('loglik', nan), '.1f')}"
                f"</td><td>{r.get('k', '')}</td><td>{fmt(r.get('delta_bic', nan), '.2f')}</td>"
                f"<td>{fmt(r.get('weight_bic', nan), '.3g')}</td>"
                f"<td class=l>{html.escape(str(r.get('error', r.get('screened', ''))))}</td></tr>"
                for r in m.selection.table)
            out.append(f"<h3>{axis}</h3><table><tr><th class=l>candidate</th><th>log-lik</th><th>k</th>"
                       f"<th>ΔBIC</th><th>BIC weight</th><th class=l>note</th></tr>{rows}</table>")
        final = result.finals[axis].fit if axis in result.finals else m.fit  # the model users paste
        name = result.finals[axis].model if axis in result.finals else m.fit.model
        advice = final.record_length
        if advice is not None:
            from_zero = final.not_resolved_from_zero
            items = "".join(
                f"<li>{html.escape(lab)}: not resolved from zero (its 95 % interval reaches 0): no record length gives "
                "it a relative precision</li>" if lab in from_zero else
                f"<li>{html.escape(lab)}: no upper end (its 95 % interval is unbounded above): this record gives no "
                "precision to extrapolate</li>" if not math.isfinite(advice.needed_s[lab]) else
                f"<li>{html.escape(lab)}: {fmt(advice.needed_s[lab] / 3600, '.3g')} h for ±{100 * advice.target:.0f} % "
                f"(now ±{100 * advice.relative_halfwidth[lab]:.0f} %)"
                + ("" if advice.reliable[lab] else " — a lower bound (correlation time not ≪ record)") + "</li>"
                for lab in advice.needed_s)
            out.append(f"<p>How long to record ({html.escape(name)}, now {advice.current_s / 3600:.2f} h):"
                       f"</p><ul>{items}</ul>")
    return "\n".join(out)


def _gmwm_section(result: AnalysisResult) -> str:
    """Per axis with a GMWM fit: its J-test and misfitting τ, the WIC ranking, and the EM comparison row by row."""
    out = ["<h2 id=gmwm>GMWM (wavelet variance) and the EM side by side</h2>"
           "<p class=small>The GMWM fits the model to the Haar wavelet variance (half the Allan variance at "
           "τ = 2^j·dt). Its J-test says whether the model can produce that curve; the scales with |z| &gt; 2 are "
           "where it cannot. With both estimators, a parameter whose two estimates differ beyond their intervals "
           "means the model is wrong somewhere.</p>"]
    for axis, m in result.models.items():
        g = m.gmwm
        if g is None:
            continue
        misfit = [f"{fmt(t, '.3g')}" for t, z in zip(g.wv.tau, g.residual_z, strict=False) if abs(z) > 2]
        robust = "; robust wavelet variance" if g.wv.robust else ""
        out.append(f"<h3>{axis}: GMWM {html.escape(g.model)}</h3><p>J = {fmt(g.j_statistic, '.4g')} with {g.dof} "
                   f"degrees of freedom, p = {fmt(g.p_value, '.3g')}; misfitting τ [s]: "
                   f"{', '.join(misfit) or 'none'}{robust}.</p>")
        if m.gmwm_selection is not None:
            rows = "".join(f"<tr><td class=l>{html.escape(str(r['model']))}</td><td>{r.get('k', '')}</td>"
                           f"<td>{fmt(r.get('delta_wic', float('nan')), '.2f')}</td>"
                           f"<td>{fmt(r.get('p_value', float('nan')), '.3g')}</td>"
                           f"<td class=l>{html.escape(str(r.get('error', r.get('line', ''))))}</td></tr>"
                           for r in m.gmwm_selection.table)
            out.append("<table><tr><th class=l>candidate</th><th>k</th><th>ΔWIC</th><th>J-test p</th>"
                       f"<th class=l>error or line offered</th></tr>{rows}</table>")
        c = m.comparison
        if c is not None:
            rows = "".join(f"<tr><td class=l>{html.escape(r.quantity)}</td><td>{_ci(r.em, r.em_ci)}</td>"
                           f"<td>{_ci(r.gmwm, r.gmwm_ci)}</td><td>{fmt(r.ratio, '.3f')}</td>"
                           f"<td>{r.verdict}</td></tr>" for r in c.rows)
            out.append("<table><tr><th class=l>parameter</th><th>EM, 95 %</th><th>GMWM, 95 %</th><th>ratio</th>"
                       f"<th>verdict</th></tr>{rows}</table><p>{html.escape(c.verdict)}</p>")
    return "\n".join(out)


def report_sections(result: AnalysisResult, meta: dict) -> list[Callable[[], str]]:
    """The sections of ``report.html`` in order, each a task that returns its HTML (figures embedded) from
    ``result`` and ``meta`` alone: the data, the numbers, the overbound, one Allan panel per axis, the selection, the
    GMWM and one closed-loop section per axis, so that :func:`~.forked.run_tasks` can draw the figures side by
    side. :func:`assemble_report` joins what they return."""
    tasks: list[Callable[[], str]] = [partial(_data_section, result, meta)]
    if result.finals:
        tasks += [partial(_numbers_section, result), partial(_overbound_section, result),
                  partial(str, "<h2 id=allan>Allan deviation per axis</h2>"),
                  *(partial(_allan_panel, result, axis) for axis in result.finals),
                  partial(_selection_section, result)]
    if any(m.gmwm is not None for m in result.models.values()):
        tasks.append(partial(_gmwm_section, result))
    if result.loops:
        tasks.append(partial(str, f"<h2 id=loop>Closed loop</h2>{LOOP_INTRO}"))
        tasks += [partial(loop_axis_section, axis, r) for axis, r in result.loops.items()]
    return tasks


def assemble_report(sections: list[str], title: str) -> str:
    """The HTML text of the analysis report (module docstring) from its sections' HTML (:func:`report_sections`)."""
    nav = " · ".join(f"<a href='#{a}'>{t}</a>" for a, t in (("data", "data"), ("numbers", "numbers"),
                                                             ("overbound", "overbound"), ("allan", "Allan"),
                                                             ("selection", "selection"), ("gmwm", "GMWM"),
                                                             ("loop", "closed loop")))
    body = "\n".join(sections)
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
            f"<style>{STYLE}</style></head><body><h1>{html.escape(title)}</h1>"
            f"<p class=small>{nav}</p>{body}</body></html>")
