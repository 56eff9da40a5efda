"""Fixed figure margins in inches, instead of matplotlib's tight or constrained layout.

``tight_layout`` draws every tick label and title once to measure it before the figure is drawn again to be saved;
on the log-log Allan panels (many minor ticks, mathtext labels) writing an analysis took 1.6× as long with it, and
the figures were then 38 % of a short ``analyze`` (``bench/bench_figures.py`` → ``docs/results/bench_figures.txt``).
The figures here have known contents (labels at known font sizes), so margins sized once in inches hold at any
figure size (``test/test_report_layout.py``).
"""

from __future__ import annotations

#: Room [in] for log-axis tick labels (mathtext powers of ten) and an axis label beside or below them.
LEFT, BOTTOM = 0.85, 0.6
#: Room [in] for an axes title above a panel, and for a figure's suptitle above that.
TITLE, SUPTITLE = 0.35, 0.3
#: Room [in] to the right of the last panel.
RIGHT = 0.15


def fix_margins(fig, *, left: float = LEFT, bottom: float = BOTTOM, right: float = RIGHT, top: float = TITLE,
                suptitle: bool = False, wspace: float = LEFT + 0.1, hspace: float = BOTTOM + TITLE) -> None:
    """Place the subplots of ``fig`` with margins and gaps given in inches (not figure fractions).

    Parameters
    ----------
    fig
        A matplotlib figure made with ``plt.subplots`` (a regular grid).
    left, bottom, right, top
        Margins [in]; ``top`` holds the panels' titles.
    suptitle
        Also leave :data:`SUPTITLE` above ``top`` for ``fig.suptitle``.
    wspace, hspace
        Gaps between panels [in]: the next panel's y labels, the lower panel's title and the upper's x labels.
    """
    width, height = fig.get_size_inches()
    grid = fig.axes[0].get_subplotspec().get_gridspec() if fig.axes else None
    rows, cols = grid.get_geometry() if grid is not None else (1, 1)
    top_in = top + (SUPTITLE if suptitle else 0.0)
    panel_w = (width - left - right - (cols - 1) * wspace) / cols
    panel_h = (height - bottom - top_in - (rows - 1) * hspace) / rows
    fig.subplots_adjust(left=left / width, right=1.0 - right / width, bottom=bottom / height,
                        top=1.0 - top_in / height, wspace=wspace / panel_w, hspace=hspace / panel_h)
