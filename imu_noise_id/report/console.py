"""What the commands print: the Allan-slope noise density and random walk per axis, the closed loop's steps, the
recording-length advice and the overbound."""

from __future__ import annotations

import math
from collections.abc import Iterable

from ..core.axes import AXES, UNITS
from ..core.estimation.em.mle import physical_bounds
from ..core.estimation.em.results import FitResult
from ..core.estimation.readouts.kalibr import walk_crossing_tau
from ..core.noise.components import RW
from ..core.noise.modelspec import parameter_labels
from ..pipelines.analyze.final import FinalModel
from ..pipelines.analyze.models import AxisModel
from ..pipelines.analyze.numbers import UPPER_BOUND_METHODS, PastedNumbers, axis_readings
from ..pipelines.analyze.overbound import ALLAN_SLOPES, AxisOverbound
from ..pipelines.analyze.static import StaticAnalysis
from ..pipelines.av_band import av_band_claim
from ..pipelines.loop import LoopResult

_SUMMARY_UNITS = {"rad/s": ("rad/s/sqrt(Hz)", "rad/s^2/sqrt(Hz)"), "m/s^2": ("m/s^2/sqrt(Hz)", "m/s^3/sqrt(Hz)")}


def _fmt(x: float) -> str:
    return f"{x:.3e}" if math.isfinite(x) else "n/a"


def summary_table(result: StaticAnalysis, numbers: PastedNumbers | None = None) -> str:
    """Short text table: per axis the Allan-slope white-noise density and random walk with their intervals. With the
    analysis's ``numbers``: labelled as the slopes' readings (not what imu.yaml pastes where final models give it),
    and below it each reading whose interval does not overlap the pasted number's (:func:`allan_disagreement_lines`)."""
    conf = 100 * result.allan.confidence
    lines = [
        f"{result.n} samples, {result.duration_s:.1f} s at {result.rate_hz:.6g} Hz ({result.topic or 'input'})",
    ]
    if numbers is not None:
        modelled = any(s.from_models for s in numbers.sensors.values())
        lines.append("Allan-slope readings (IEEE Std 952 lines: N the -1/2 line at tau = 1 s, K the +1/2 line at "
                     "tau = 3 s; " + ("imu.yaml pastes the final models' numbers, below):" if modelled
                                      else "the numbers imu.yaml pastes):"))
    if result.period is not None and not result.period.trusted:
        lines.append(f"!! sample rate {result.period.describe()}: the stamps cannot be taken at face value (see the "
                     "warnings; --rate HZ gives the rate)")
    lines.append(f"{'axis':8s} {'noise density':>13s} {f'{conf:.0f}% CI':>23s}   {'random walk':>11s} "
                 f"{f'{conf:.0f}% CI':>23s}  unit (N; K)")
    for a in result.axes:
        s = result.slopes[a]
        n, k = s.noise_density, s.random_walk
        k_val = ("<" if k.method == "upper_bound" else " ") + _fmt(k.value)
        n_val = ("<" if n.method == "upper_bound" else " ") + _fmt(n.value)
        u_n, u_k = _SUMMARY_UNITS[UNITS[a]]
        lines.append(
            f"{a:8s} {n_val:>13s} [{_fmt(n.ci[0])}, {_fmt(n.ci[1])}]   {k_val:>11s} [{_fmt(k.ci[0])}, {_fmt(k.ci[1])}]"
            f"  {u_n}; {u_k}"
        )
    lines.append("('<': upper bound, slope not reached in this record)")
    if numbers is not None:
        lines += allan_disagreement_lines(result, numbers)
    return "\n".join(lines)


#: Per parameter: its symbol and the Allan-deviation slope of its line.
_SLOPE_LINES = {"noise_density": ("N", "-1/2"), "random_walk": ("K", "+1/2")}


def allan_disagreement_lines(result: StaticAnalysis, numbers: PastedNumbers) -> list[str]:
    """One line per axis and parameter whose Allan-slope reading and pasted number have 95 % intervals that share no
    value (:meth:`~..pipelines.analyze.numbers.AxisNumbers.allan_disagreements`): both with their intervals, the τ
    range the line was read over, the final model, and which one imu.yaml pastes."""
    lines = []
    for sensor in numbers.sensors.values():
        for a in sensor.axes:
            for parameter in a.allan_disagreements():
                symbol, slope = _SLOPE_LINES[parameter]
                allan, pasted = a.allan_reading(parameter), a.reading(parameter)
                lo, hi = getattr(result.slopes[a.axis], parameter).tau_range
                model = f" ({a.model.name})" if a.model is not None else ""
                slope_text = _reading_text(allan.value, allan.ci95, allan.method)
                lines.append(f"{a.axis:8s} the Allan slope's {symbol} {slope_text} (its {slope} line, read over tau "
                             f"{lo:.3g}-{hi:.3g} s) and the final model's "
                             f"{_reading_text(pasted.value, pasted.ci95, pasted.method)} ({pasted.method}) do not "
                             f"overlap: the line takes the Allan variance there as white noise and a random walk "
                             f"alone, the final model{model} is fitted to the whole record; imu.yaml pastes the final "
                             "model's, *_allan_xyz keeps the slope's")
    return lines


def _reading_text(value: float | None, ci95: tuple[float, float], method: str) -> str:
    """A value with its interval, '<' before an upper bound, the method named where the Allan slopes stand in."""
    if value is None:
        return "not identifiable (see imu.yaml *_allan)"
    mark = "<" if method in UPPER_BOUND_METHODS else ""
    named = f" ({method})" if method.startswith("allan") else ""
    return f"{mark}{_fmt(value)} [{_fmt(ci95[0])}, {_fmt(ci95[1])}]{named}"


#: The least width of a table's model-name column (longer names widen it for every row).
NAME_WIDTH = 22


def _name_width(names: Iterable[str]) -> int:
    """The model-name column's width: :data:`NAME_WIDTH`, or the longest of ``names``."""
    return max([NAME_WIDTH, *(len(name) for name in names)])


def final_table(finals: dict[str, FinalModel], static: StaticAnalysis | None = None,
                numbers: PastedNumbers | None = None) -> str:
    """Per axis the final model, N and K with 95 % intervals as imu.yaml pastes them (``numbers``, the analysis's;
    without them the final models' own values); below, each K above what the long-τ AV supports, with its source's
    reason."""
    lines = ["Final models (imu.yaml's numbers; N = passband white noise, K = random walk, B = bias instability, "
             "'<' an upper bound; 95 % intervals):"]
    width = _name_width(f.model for f in finals.values())
    for axis, f in finals.items():
        pasted = numbers.axis(axis) if numbers is not None and axis in AXES else None
        n, k = (pasted.noise_density, pasted.random_walk) if pasted is not None else (f.noise_density, f.random_walk)
        n_text = _reading_text(n.value, n.ci95, n.method) if n.value is not None else "n/a"
        k_text = _reading_text(k.value, k.ci95, k.method)
        b = f.bias_instability
        b_text = _reading_text(b.value, b.ci95, b.method())
        lines.append(f"{axis:8s} {f.model:{width}s} N {n_text:34s} K {k_text:34s} B {b_text}")
    lines += [f"{axis:8s} K flagged: {f.random_walk.source}" for axis, f in finals.items() if f.random_walk_above_bound]
    lines += [f"{axis:8s} K's interval spans the structures the data cannot tell apart: "
              + "; ".join(r.describe() for r in f.walk_readings) for axis, f in finals.items() if f.walk_readings]
    lines += [f"{axis:8s} N and K unresolved (upper bounds: the overbound's): {f.unresolved}"
              if f.noise_density.method == "unresolved" else
              f"{axis:8s} K unresolved (an upper bound: the overbound's; N the model's, confirmed by the data's "
              f"passband level): {f.unresolved}"
              for axis, f in finals.items() if f.unresolved]
    lines += short_for_walk_lines(finals, static)
    return "\n".join(lines)


def short_for_walk_lines(finals: dict[str, FinalModel], static: StaticAnalysis | None = None) -> list[str]:
    """Per axis too short for K (K a bound, or the walk crossing the white-noise floor beyond a third of the record,
    ``kalibr.walk_crossing_tau``): that τ, the record length identifying such a walk (3τ) and what was given.
    ``static``: the Allan stage (its slope reading of K for an axis whose final model has no random walk)."""
    lines = []
    for axis, f in finals.items():
        n, k, method = f.noise_density.value, f.random_walk.value, f.random_walk.method
        if k is None and static is not None and axis in static.slopes:  # what imu.yaml pastes instead
            walk = axis_readings(static, axis, f)[1]
            k, method = walk.value, ("Allan-slope bound" if walk.method == "allan_upper_bound" else "Allan slope")
        if not n or not k:
            continue
        record = f.fit.n * f.fit.dt
        crossing = walk_crossing_tau(n, k)
        bounded = method in ("bound", "unresolved", "Allan-slope bound")
        if not bounded and crossing <= record / 3.0:
            continue
        if bounded:
            smallest = walk_crossing_tau(n, 1.0) / (record / 3.0)  # K whose walk crosses at a third of the record
            lines.append(f"{axis:8s} K not identified by this {_duration(record)} record ({_why_bound(f, method)}"
                         "): a record identifies walks well above "
                         f"3*sqrt(3)*N/T = {_fmt(smallest)} here, each tenfold smaller walk needs a tenfold longer "
                         f"record; given: K <= {_fmt(k)} ({method})")
        else:
            lines.append(f"{axis:8s} too short for K: the walk of {_fmt(k)} crosses the white-noise floor at tau = "
                         f"{_duration(crossing)}, beyond a third of this {_duration(record)} record; record "
                         f"{_duration(3.0 * crossing)} or more to identify it. Given meanwhile: K = {_fmt(k)} "
                         f"({method})")
    return lines


def _why_bound(f: FinalModel, method: str) -> str:
    """Why the K given for ``f`` is a bound (``method`` as :func:`short_for_walk_lines` reads it): the reason that
    applies, in words."""
    if method == "unresolved":
        return "the closed loop's verdict failed: the overbound's K"
    if method == "Allan-slope bound":
        return "the final model has no random walk: the Allan slope's bound"
    if f.walk_readings:
        return "structures the data cannot tell apart read it otherwise: the upper end of their span"
    if not any(isinstance(c, RW) for c in f.fit.components):
        return "the final model has no random walk: the long-τ AV bounds it"
    if not math.isfinite(f.fit.ci95.get("RW.random_walk", (0.0, math.inf))[1]):
        return "its 95 % interval reaches zero and has no upper end: the long-τ AV bounds it"
    return "its 95 % interval reaches zero"


def loop_table(results: dict[str, LoopResult]) -> str:
    """One line per step: axis, step, change (added +, dropped −), model, errors; then the verdict."""
    lines = [f"{'axis':8s} {'step':>4s} {'change':10s} {'model':24s} {'loglik':>12s} {'BIC':>12s} {'AVmis':>6s} "
             f"{'LB p':>8s} {'peak':>6s}"]
    for axis, r in results.items():
        for s in r.steps:
            e = s.errors
            change = ("" if s.added is None else f"+{s.added}") + "".join(f" −{d}" for d in s.dropped)
            lines.append(f"{axis:8s} {s.index:4d} {change:10s} {s.model:24s} {e.loglik:12.1f} {e.bic:12.1f} "
                         f"{e.av_misfit:6.3f} {e.ljung_box_p:8.2g} {e.peak_ratio:6.1f}")
        lines.append(f"{axis:8s}      -> {r.verdict}" + (f" ({r.note})" if r.note else ""))
        lines.append(f"{axis:8s}         {av_band_claim(r).sentence()}")
    return "\n".join(lines)


def fit_line(axis: str, fit: FitResult) -> str:
    """One line per fitted axis: the model, its log-likelihood and BIC (a GMWM fit: its J-test), the components."""
    if fit.estimator == "gmwm":
        quality = f"GMWM J {fit.j_statistic:.4g} (dof {fit.dof}, p {fit.p_value:.3g})"
    else:
        quality = f"loglik {fit.loglik:.6g}  BIC {fit.bic:.6g}"
    return f"{axis}: {fit.model}  {quality}  " + "  ".join(str(c) for c in fit.components)


def parameter_lines(axis: str, fit: FitResult) -> list[str]:
    """One line per fitted parameter: its value, unit (the component's, u the axis's unit), 95 % interval and how the
    interval was computed (``ci95_method``), as model.yaml holds them; "interval not determined" where it has none;
    a value at an end of the range searched (:func:`~..core.estimation.em.mle.physical_bounds`) or one whose interval
    holds zero (:func:`_from_zero`) says so."""
    lines = []
    for i, name, label in parameter_labels(list(fit.components)):
        component = fit.components[i]
        unit = component.parameter_units.get(name, "")
        unit = UNITS.get(axis, "u") + unit[1:] if unit.startswith("u") else unit
        lo, hi = fit.ci95.get(label, (math.nan, math.nan))
        interval = (f"[{lo:.4g}, {hi:.4g}] ({fit.ci95_method.get(label, 'method not recorded')})"
                    if math.isfinite(lo) and math.isfinite(hi) else "interval not determined")
        unit_text = f"  [{unit}]" if unit else ""
        value = component.params()[name]
        lines.append(f"{axis:8s}   {label:24s} {value:.4g} {interval}{unit_text}{_range_end(name, value, fit)}"
                     f"{_from_zero(lo, hi)}")
    return lines


def _from_zero(lo: float, hi: float) -> str:
    """What an interval (lo, hi) holding zero says: a scale (lo = 0) is only bounded, a signed value (a ramp) not
    told from none; "" otherwise."""
    if not lo <= 0.0 <= hi:
        return ""
    if lo == 0.0:
        return f"; not resolved from zero: the record only bounds it, <= {hi:.4g}"
    return "; its interval holds zero: the record does not tell it from none"


#: Relative distance from an end of the range searched within which a value is said to lie at it.
RANGE_END_TOLERANCE = 1e-3
#: What an end of a searched range is, where it has a name: (parameter, end) → words.
_RANGE_END_NAMES = {("tau", "lower"): "one sample", ("frequency", "upper"): "Nyquist", ("cutoff", "upper"): "Nyquist",
                    ("bandwidth", "upper"): "Nyquist"}


def _range_end(name: str, value: float, fit: FitResult) -> str:
    """"; at the lower/upper end of the range searched (…)" when ``value`` of parameter ``name`` lies within
    :data:`RANGE_END_TOLERANCE` of an end of :func:`~..core.estimation.em.mle.physical_bounds`, else ""."""
    bounds = physical_bounds(fit.n, fit.dt).get(name)
    if bounds is None:
        return ""
    if value <= bounds[0] * (1.0 + RANGE_END_TOLERANCE):
        end, at = "lower", bounds[0]
    elif value >= bounds[1] * (1.0 - RANGE_END_TOLERANCE):
        end, at = "upper", bounds[1]
    else:
        return ""
    named = _RANGE_END_NAMES.get((name, end))
    return f"; at the {end} end of the range searched ({at:.4g} {'s' if name == 'tau' else 'Hz'}" + \
        (f": {named})" if named else ")")


def comparison_table(models: dict[str, AxisModel]) -> str:
    """EM and GMWM side by side per axis and parameter (95 % intervals), each row's verdict, each axis's verdict."""
    lines = ["EM and GMWM side by side (95 % intervals; 'differ': |ln ratio| > 1.96 combined log-sd):",
             f"{'axis':8s} {'quantity':26s} {'EM':>34s} {'GMWM':>34s} {'ratio':>6s}  verdict"]
    for axis, m in models.items():
        c = m.comparison
        if c is None:
            continue
        for r in c.rows:
            em = f"{_fmt(r.em)} [{_fmt(r.em_ci[0])}, {_fmt(r.em_ci[1])}]"
            gm = f"{_fmt(r.gmwm)} [{_fmt(r.gmwm_ci[0])}, {_fmt(r.gmwm_ci[1])}]"
            lines.append(f"{axis:8s} {r.quantity:26s} {em:>34s} {gm:>34s} {r.ratio:6.3f}  {r.verdict}")
        lines.append(f"{axis:8s} -> {c.verdict}")
    return "\n".join(lines)


def loop_line(axis: str, loop: LoopResult, selected: str | None = None) -> str:
    """Per axis: first and final model and the verdict, then where the final AV lies against the data's band
    (:func:`~imu_noise_id.pipelines.av_band.av_band_claim`); ``selected``: the model stage's model, explained when
    the loop's first step names it otherwise."""
    start = loop.steps[0].model
    why = "" if selected is None or selected == start else f" ({_start_renamed(selected, start)})"
    return (f"{axis}: loop {start}{why} -> {loop.final.model}: {loop.verdict}\n"
            f"  {av_band_claim(loop).sentence()}")


def _start_renamed(selected: str, start: str) -> str:
    """Why the loop's first step is named ``start`` where the model stage fitted ``selected``."""
    if "LPF" in start.split("+") and "LPF" not in selected.split("+"):
        return (f"the fitted {selected} with its shortest GM read as the sensor's low-pass: its τ is below the "
                "filter's memory limit (five samples or 50 ms)")
    return f"the fitted {selected}, renamed"


def _duration(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "n/a"
    return f"{seconds / 3600:.3g} h" if seconds >= 3600 else f"{seconds / 60:.3g} min"


def record_length_lines(fits: dict[str, FitResult], names: dict[str, str] | None = None) -> list[str]:
    """How long to record per axis: the longest needed duration over the parameters the record bounds (their 95 %
    interval's lower end above 0 and its upper end finite) and which one, then the others by name: a relative precision
    of a value the data cannot tell from zero, or without an upper end, is no finite record's. ``names``: the model's
    name per axis where it is not the fit's own."""
    lines = []
    width = _name_width((names or {}).get(axis, fit.model) for axis, fit in fits.items())
    for axis, fit in fits.items():
        advice = fit.record_length
        if advice is None or not advice.needed_s:
            continue
        zero = set(fit.not_resolved_from_zero)
        from_zero = [lab for lab in advice.needed_s if lab in zero]
        unbounded = [lab for lab in advice.needed_s if lab not in zero and not math.isfinite(advice.needed_s[lab])]
        resolved = [lab for lab in advice.needed_s if lab not in from_zero and lab not in unbounded]
        if not resolved:
            continue
        label = max(resolved, key=advice.needed_s.get)
        needed = advice.needed_s[label]
        verdict = "enough" if needed <= advice.current_s else f"record {_duration(needed)}"
        bound = "" if advice.reliable[label] else " (a lower bound: correlation time not << record)"
        name = (names or {}).get(axis, fit.model)
        which = ("every parameter the record bounds" if unbounded else
                 "every parameter resolved from zero" if from_zero else "every parameter")
        left_out = (f"; not resolved from zero, left out: {', '.join(from_zero)}" if from_zero else "") + \
            (f"; no upper end, left out: {', '.join(unbounded)}" if unbounded else "")
        lines.append(f"{axis:8s} {name:{width}s} now {_duration(advice.current_s)}: {verdict} for +-"
                     f"{100 * advice.target:.0f} % on {which} (hardest: {label}, now +-"
                     f"{100 * advice.relative_halfwidth[label]:.0f} %){bound}{left_out}")
    if lines:
        lines.insert(0, "How long to record (95 % half-widths; model.yaml record_length):")
    return lines


def overbound_lines(overbounds: dict[str, AxisOverbound]) -> list[str]:
    """Per axis the overbound N and K with their inflation factors over imu.yaml's values (an axis analysed without a
    model: over its Allan-slope readings, said on its line)."""
    if not overbounds:
        return []
    first = next(iter(overbounds.values()))
    lines = [f"Overbound (imu.yaml overbound:): smallest WN+RW above {first.covers.split(' (')[0]} for tau "
             f"{first.tau_range[0]:.3g}-{first.tau_range[1]:.3g} s:"]
    for axis, o in overbounds.items():
        over = ("  (factors over its Allan-slope readings: the axis was not analysed with a model)"
                if o.reference_source == ALLAN_SLOPES else "")
        lines.append(f"{axis:8s} N {_fmt(o.noise_density)} (x{o.inflation_noise_density:.3g})  "
                     f"K {_fmt(o.random_walk)} (x{o.inflation_random_walk:.3g}){over}")
    return lines
