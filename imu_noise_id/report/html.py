"""The closed loop's part of ``report.html`` (:mod:`.analysis_html`): per axis, each step with the effect added, the
evidence, the errors before and after, the Allan plots before/after and the residual ACF/PSD (PNG embedded as
base64); the style every report shares."""

from __future__ import annotations

import base64
import html

from ..core.axes import UNITS
from ..pipelines.av_band import av_band_claim
from ..pipelines.loop import LoopResult
from .loop_plots import allan_before_after, residual_acf_psd
from .loop_yaml import HOW

STYLE = """
body{font-family:sans-serif;max-width:1000px;margin:2em auto;color:#222}
table{border-collapse:collapse;font-size:0.85em;margin:0.5em 0}
td,th{border:1px solid #ccc;padding:3px 6px;text-align:right}
td.l,th.l{text-align:left}
.pass{color:#176317;font-weight:bold}.fail{color:#a33;font-weight:bold}
img{max-width:100%}
.small{font-size:0.8em;color:#555}
.warn{border:2px solid #a33;background:#fdecea;padding:0.5em}
"""


def img_tag(png: bytes, alt: str) -> str:
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{base64.b64encode(png).decode()}">'


def fmt(x: float, spec: str = ".4g") -> str:
    return format(float(x), spec)


#: What the loop does and what its error measures are, in front of its axes' sections.
LOOP_INTRO = ("<p>Each step fits the model, tests its residuals (standardised one-step innovations and the Allan "
              "variance against the model's) with the detectors of missing effects, adds the most significant effect "
              "that lowers the BIC and removes its evidence, and refits. SIN, TEMP and STEP enter as deterministic "
              "regressors of the measurement equation, OUTLIERS as data cleaning (flagged samples replaced by the "
              "model's one-step prediction); GM, RW, RR and QN are state-space components. Error measures: "
              "log-likelihood and BIC (comparable across steps), AV misfit = RMS of log10(AV_data/AV_model) over τ, "
              "Ljung–Box p-value of the standardised innovations (20 lags), and the largest periodogram line of the "
              "innovations over its local median.</p>")


def loop_axis_section(axis: str, result: LoopResult) -> str:
    unit = UNITS.get(axis, "u")
    out = [f"<h2>{html.escape(axis)}</h2>"]
    cls = "pass" if result.passed else "fail"
    out.append(f'<p>Final model <b>{html.escape(result.final.model)}</b>; verdict: '
               f'<span class="{cls}">{html.escape(result.verdict)}</span></p>')
    out.append(f"<p class=small>{html.escape(av_band_claim(result).sentence(), quote=False)}"
               + (f" {html.escape(result.note)}" if result.note else "") + "</p>")
    rows = ["<tr><th>step</th><th class=l>model</th><th class=l>added (how)</th><th>log-lik</th><th>BIC</th>"
            "<th>AV misfit</th><th>Ljung–Box p</th><th>peak ratio</th><th class=l>evidence</th></tr>"]
    for s in result.steps:
        e = s.errors
        how = "" if s.added is None else f"{s.added} ({HOW.get(s.added, 'state-space component')})"
        how += "".join(f"; dropped {d}" for d in s.dropped)
        rows.append(
            f"<tr><td>{s.index}</td><td class=l>{html.escape(s.model)}</td><td class=l>{html.escape(how)}</td>"
            f"<td>{fmt(e.loglik, '.1f')}</td><td>{fmt(e.bic, '.1f')}</td><td>{fmt(e.av_misfit, '.3f')}</td>"
            f"<td>{fmt(e.ljung_box_p, '.2g')}</td><td>{fmt(e.peak_ratio, '.1f')}</td>"
            f"<td class=l>{html.escape(s.evidence or '')}</td></tr>")
    out.append("<table>" + "".join(rows) + "</table>")
    fitted = ", ".join(str(c) for c in result.final.diagnosis.fit.components)
    out.append(f"<p class=small>Fitted components: {html.escape(fitted)}</p>")
    if result.final.diagnosis.exog_values:
        reg = "; ".join(f"{k}: " + ", ".join(f"{p} = {v:.4g}" for p, v in vals.items())
                        for k, vals in result.final.diagnosis.exog_values.items())
        out.append(f"<p class=small>Regressors: {html.escape(reg)}</p>")
    if result.final.state.flagged.size:
        out.append(f"<p class=small>Outliers removed: {result.final.state.flagged.size} samples</p>")
    if result.remaining:
        items = "".join(f"<li>{html.escape(f.evidence)}</li>" for f in result.remaining)
        out.append(f"<p>Unexplained (still significant):</p><ul>{items}</ul>")
    rejected = [(s.index, t) for s in result.steps for t in s.trials if not t.accepted]
    if rejected:
        items = "".join(f"<li>after step {i}: {html.escape(t.model)} — {html.escape(t.reason)}</li>"
                        for i, t in rejected)
        out.append(f"<details><summary>Candidates tried and not kept ({len(rejected)})</summary><ul>{items}</ul>"
                   "</details>")
    pairs = list(zip(result.steps[:-1], result.steps[1:], strict=False)) or [(result.steps[0], None)]
    residuals: dict[int, str] = {}  # a step between two others shows its residuals in both pairs: drawn once
    for before, after in pairs:
        label = f"{axis}: step {before.index}" + (f" → {after.index} (+{after.added})" if after else "")
        out.append(f"<h3>{html.escape(label)}</h3>")
        out.append(img_tag(allan_before_after(before, after, unit, label), f"Allan deviation {label}"))
        for s in (before, after) if after else (before,):
            if s.index not in residuals:
                residuals[s.index] = img_tag(residual_acf_psd(s, f"{axis} step {s.index}: {s.model}"),
                                             f"residual ACF and PSD, step {s.index}")
            out.append(residuals[s.index])
    return "\n".join(out)
