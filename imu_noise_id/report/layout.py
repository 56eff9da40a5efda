"""Fixed figure margins in inches instead of matplotlib's tight or constrained layout (docs/analysis.md, "Why the
figures are drawn as they are")."""

from __future__ import annotations

#: Room [in] for log-axis tick labels (mathtext powers of ten) and an axis label beside or below them.
LEFT, BOTTOM = 0.85, 0.6
#: Room [in] for an axes title above a panel, and for a figure's suptitle above that.
TITLE, SUPTITLE = 0.35, 0.3
#: Room [in] to the right of the last panel.
RIGHT = 0.15


def fix_margins(fig, *, left: float = LEFT, bottom: float = BOTTOM, right: float = RIGHT, top: float = TITLE,
                suptitle: bool = False, wspace: float = LEFT + 0.1, hspace: float = BOTTOM + TITLE) -> None:
    """Place the subplots of ``fig`` (a regular ``plt.subplots`` grid) with margins and gaps in inches.

    Parameters
    ----------
    left, bottom, right, top : margins [in]; ``top`` holds the panels' titles
    suptitle : also leave :data:`SUPTITLE` above ``top`` for ``fig.suptitle``
    wspace, hspace : gaps between panels [in]
    """
    width, height = fig.get_size_inches()
    grid = fig.axes[0].get_subplotspec().get_gridspec() if fig.axes else None
    rows, cols = grid.get_geometry() if grid is not None else (1, 1)
    top_in = top + (SUPTITLE if suptitle else 0.0)
    panel_w = (width - left - right - (cols - 1) * wspace) / cols
    panel_h = (height - bottom - top_in - (rows - 1) * hspace) / rows
    fig.subplots_adjust(left=left / width, right=1.0 - right / width, bottom=bottom / height,
                        top=1.0 - top_in / height, wspace=wspace / panel_w, hspace=hspace / panel_h)
