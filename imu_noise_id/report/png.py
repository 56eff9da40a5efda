"""Every report figure leaves through here: written as PNG (to a file or to bytes) and closed; log axes thinned
(:data:`LOG_MINOR_SUBS`) and labelled in plain text (:data:`PLAIN_POWERS`; docs/analysis.md, "Why the figures …")."""

from __future__ import annotations

import io
import re
from pathlib import Path

from matplotlib.ticker import Formatter

#: Minor ticks of a log axis, as multiples of each power of ten.
LOG_MINOR_SUBS: tuple[float, ...] = (2.0, 5.0)
#: Smallest ratio of a log axis's limits whose minor ticks are thinned (a decade: no minor tick labels).
THIN_FROM_RATIO = 10.0
#: Whether log axes' powers of ten are written as plain text (False: matplotlib's mathtext).
PLAIN_POWERS = True

_SUPERSCRIPT = str.maketrans("0123456789-\u2212", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻⁻")
_MATHTEXT_POWER = re.compile(
    r"^\$\\mathdefault\{(?:(?P<mantissa>[0-9.]+)\\times\s*)?10\^\{(?P<exponent>[-\u2212]?\d+)\}\}\$$")


def plain_power(label: str) -> str:
    """A log axis's mathtext label such as ``$\\mathdefault{2\\times10^{-3}}$`` as plain text ``2×10⁻³``; any other
    label unchanged."""
    match = _MATHTEXT_POWER.match(label)
    if match is None:
        return label
    mantissa = f"{match['mantissa']}×" if match["mantissa"] else ""
    return f"{mantissa}10{match['exponent'].translate(_SUPERSCRIPT)}"


class PlainPowers(Formatter):
    """A log axis's tick formatter (``inner``) with its powers of ten as plain text (:func:`plain_power`)."""

    def __init__(self, inner: Formatter) -> None:
        self.inner = inner

    def set_axis(self, axis) -> None:
        super().set_axis(axis)
        self.inner.set_axis(axis)

    def set_locs(self, locs) -> None:
        self.inner.set_locs(locs)

    def __call__(self, x: float, pos: int | None = None) -> str:
        return plain_power(self.inner(x, pos))


def plain_log_labels(fig) -> None:
    """Write the tick labels of every log-scaled axis of ``fig`` as plain text (:class:`PlainPowers`)."""
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            if axis.get_scale() == "log":
                for get, put in ((axis.get_major_formatter, axis.set_major_formatter),
                                 (axis.get_minor_formatter, axis.set_minor_formatter)):
                    if not isinstance(get(), PlainPowers):
                        put(PlainPowers(get()))


def thin_log_minor_ticks(fig) -> None:
    """Put the minor ticks of every log-scaled axis of ``fig`` that spans :data:`THIN_FROM_RATIO` or more at
    :data:`LOG_MINOR_SUBS` of each decade."""
    from matplotlib.ticker import LogLocator

    for ax in fig.axes:
        for axis, limits in ((ax.xaxis, ax.get_xlim), (ax.yaxis, ax.get_ylim)):
            if axis.get_scale() != "log":
                continue
            low, high = sorted(limits())
            if low > 0 and high >= THIN_FROM_RATIO * low:
                axis.set_minor_locator(LogLocator(subs=LOG_MINOR_SUBS))


def png_bytes(fig, *, dpi: float | None = None) -> bytes:
    """``fig`` as PNG bytes (``dpi`` None: the figure's own); the figure is closed."""
    buf = io.BytesIO()
    _save(fig, buf, dpi)
    return buf.getvalue()


def write_png(fig, path: str | Path, *, dpi: float | None = None) -> Path:
    """``fig`` written to ``path`` as PNG (its folder made if missing); the figure is closed."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    _save(fig, path, dpi)
    return path


def _save(fig, target, dpi: float | None) -> None:
    import matplotlib.pyplot as plt

    thin_log_minor_ticks(fig)
    if PLAIN_POWERS:
        plain_log_labels(fig)
    try:
        fig.savefig(target, format="png", **({} if dpi is None else {"dpi": dpi}))
    finally:
        plt.close(fig)
