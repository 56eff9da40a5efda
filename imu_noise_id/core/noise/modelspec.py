"""Model spec strings such as ``WN+2GM`` or ``WN(2e-4)+GM(tau=300, sigma=5e-5)`` (whitespace ignored)::

    spec := term ("+" term)*;   term := [count] NAME ["(" args ")"]
    args := value ("," value)*  |  key "=" value ("," key "=" value)*

NAME is a key of :data:`~.components.COMPONENT_TYPES`, positional values follow its ``parameter_names`` (units:
:mod:`.units`). An IMU model: ``gyro: SPEC; accel: SPEC`` (per axis ``gyro_z: SPEC``), or one SPEC for all six axes."""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Sequence

from ..axes import ACCEL_AXES, AXES, GYRO_AXES
from ..errors import InputError
from .components import COMPONENT_TYPES, Component

#: Order in which components are listed in canonical model names.
CANONICAL_ORDER: tuple[str, ...] = ("WN", "LPF", "DLPF", "MA", "QN", "BI", "GM", "OSC", "RW", "RR")


def gauss_markov_fastest_first(components: list[Component]) -> list[Component]:
    """``components`` with the GMs, in the places they hold, sorted by increasing τ (GM1 the fastest)."""
    gms = iter(sorted((c for c in components if c.name == "GM"), key=lambda c: c.params()["tau"]))
    return [next(gms) if c.name == "GM" else c for c in components]


_TERM = re.compile(r"^(?P<count>\d+)?(?P<name>[A-Za-z]+)(?:\((?P<args>[^()]*)\))?$")


class ModelSpecError(InputError):
    """A model spec string could not be understood."""


def _split_terms(spec: str) -> list[str]:
    text = re.sub(r"\s+", "", spec)
    if not text:
        raise ModelSpecError("empty model spec: give components such as 'WN+RW'")
    terms, depth, start = [], 0, 0
    for i, ch in enumerate(text):
        depth += (ch == "(") - (ch == ")")
        if ch == "+" and depth == 0:
            terms.append(text[start:i])
            start = i + 1
    terms.append(text[start:])
    if any(not t for t in terms):
        raise ModelSpecError(f"model spec {spec!r} has an empty term (check the '+' signs)")
    return terms


def _parse_term(term: str, spec: str) -> tuple[int, str, str | None]:
    match = _TERM.match(term)
    if not match:
        raise ModelSpecError(f"cannot read term {term!r} of model spec {spec!r}")
    name = match["name"].upper()
    if name not in COMPONENT_TYPES:
        known = ", ".join(COMPONENT_TYPES)
        raise ModelSpecError(f"unknown component {match['name']!r} in model spec {spec!r}: known are {known}")
    count = int(match["count"]) if match["count"] else 1
    if count < 1:
        raise ModelSpecError(f"component count must be >= 1 in {term!r}")
    return count, name, match["args"]


def parse_structure(spec: str) -> list[str]:
    """Component names of a spec, expanded (``WN+2GM`` → ``['WN', 'GM', 'GM']``), parameters ignored."""
    names: list[str] = []
    for term in _split_terms(spec):
        count, name, _ = _parse_term(term, spec)
        names.extend([name] * count)
    return names


def _parse_args(cls: type[Component], args: str, spec: str) -> dict[str, float]:
    values: dict[str, float] = {}
    items = [a for a in args.split(",") if a]
    for pos, item in enumerate(items):
        key, sep, raw = item.partition("=")
        if not sep:
            names = cls.parameter_names + cls.fixed_names
            if pos >= len(names):
                raise ModelSpecError(f"{cls.name} takes at most {len(names)} value(s) in {spec!r}")
            key, raw = names[pos], item
        if key not in cls.parameter_names + cls.fixed_names:
            raise ModelSpecError(
                f"{cls.name} has no parameter {key!r} in {spec!r}: its parameters are "
                f"{', '.join(cls.parameter_names + cls.fixed_names)}"
            )
        try:
            values[key] = float(raw)
        except ValueError:
            raise ModelSpecError(f"value {raw!r} of {cls.name}.{key} in {spec!r} is not a number") from None
    missing = [p for p in cls.parameter_names if p not in values]
    if missing:
        raise ModelSpecError(f"{cls.name} in {spec!r} needs {', '.join(missing)}")
    return values


def parse_model(spec: str) -> list[Component]:
    """Components with their parameters, e.g. ``'WN(2e-4)+GM(tau=300,sigma=5e-5)'``; ModelSpecError naming the term."""
    components: list[Component] = []
    for term in _split_terms(spec):
        count, name, args = _parse_term(term, spec)
        cls = COMPONENT_TYPES[name]
        if args is None:
            raise ModelSpecError(
                f"{name} in {spec!r} needs parameter values, e.g. {name}("
                + ", ".join(f"{p}=…" for p in cls.parameter_names) + ")"
            )
        try:
            component = cls(**_parse_args(cls, args, spec))
        except ValueError as exc:
            raise ModelSpecError(f"{name} in {spec!r}: {exc}") from None
        components.extend([component] * count)
    return components


def canonical(components: list[Component]) -> list[Component]:
    """``components`` sorted into :data:`CANONICAL_ORDER` (stable: same-named components keep their order; names
    outside it last)."""
    order = {name: i for i, name in enumerate(CANONICAL_ORDER)}
    return sorted(components, key=lambda c: order.get(c.name, len(order)))


def nests(richer: Sequence[Component], smaller: Sequence[Component]) -> bool:
    """Whether ``richer`` holds every component type of ``smaller`` (as many times): ``smaller``'s structure is
    ``richer``'s with components removed, a nested pair."""
    return not Counter(c.name for c in smaller) - Counter(c.name for c in richer)


def structure_name(names: list[str]) -> str:
    """Canonical model name: ``['GM', 'WN', 'GM', 'RW']`` → ``'WN+2GM+RW'``."""
    counts = {n: names.count(n) for n in dict.fromkeys(names)}
    ordered = [n for n in CANONICAL_ORDER if n in counts] + [n for n in counts if n not in CANONICAL_ORDER]
    return "+".join(f"{counts[n]}{n}" if counts[n] > 1 else n for n in ordered)


def model_name(components: list[Component]) -> str:
    """Canonical structure name of a list of components."""
    return structure_name([c.name for c in components])


def parse_imu_model(text: str) -> dict[str, list[Component]]:
    """Per-axis components from ``'gyro: SPEC; accel: SPEC'`` (axis keys override their group), or one SPEC for all."""
    if ":" not in text:
        components = parse_model(text)
        return {axis: list(components) for axis in AXES}
    groups = {"gyro": GYRO_AXES, "accel": ACCEL_AXES, **{a: (a,) for a in AXES}}
    result: dict[str, list[Component]] = {}
    entries = [e for e in text.split(";") if e.strip()]
    # Group keys first so that axis keys override them.
    entries.sort(key=lambda e: e.split(":", 1)[0].strip() in AXES)
    for entry in entries:
        key, _, spec = entry.partition(":")
        key = key.strip()
        if key not in groups:
            raise ModelSpecError(f"unknown axis group {key!r}: use gyro, accel or one of {', '.join(AXES)}")
        for axis in groups[key]:
            result[axis] = parse_model(spec)
    missing = [a for a in AXES if a not in result]
    if missing:
        raise ModelSpecError(f"IMU model gives no spec for {', '.join(missing)}")
    return result


def parameter_labels(components: list[Component]) -> list[tuple[int, str, str]]:
    """(component index, parameter, label), labels such as ``WN.noise_density``, ``GM2.tau`` (repeats numbered)."""
    names = [c.name for c in components]
    out = []
    seen: dict[str, int] = {}
    for i, c in enumerate(components):
        seen[c.name] = seen.get(c.name, 0) + 1
        tag = f"{c.name}{seen[c.name]}" if names.count(c.name) > 1 else c.name
        out.extend((i, p, f"{tag}.{p}") for p in c.parameter_names)
    return out
