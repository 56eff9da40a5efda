"""Every report figure leaves through here: written as PNG (to a file or to bytes) and closed.

Log axes get minor ticks at 2 and 5 of each decade instead of matplotlib's eight (2 … 9). Creating the tick objects
(two lines, a grid line and two labels each, with their properties copied) was the largest single cost of writing
an analysis, whose Allan panels span six decades on each axis: writing took 1.4× as long with every minor tick
(``bench/bench_figures.py`` → ``docs/results/bench_figures.txt``), and the grid at 1-2-5 reads as well. Only axes
spanning a decade or more are thinned: matplotlib labels no minor tick there, while on a narrower axis its minor
ticks carry the only numbers.
"""

from __future__ import annotations

import io
from pathlib import Path

#: Minor ticks of a log axis, as multiples of each power of ten.
LOG_MINOR_SUBS: tuple[float, ...] = (2.0, 5.0)
#: Smallest ratio of a log axis's limits whose minor ticks are thinned (a decade: no minor tick labels).
THIN_FROM_RATIO = 10.0


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
    try:
        fig.savefig(target, format="png", **({} if dpi is None else {"dpi": dpi}))
    finally:
        plt.close(fig)
