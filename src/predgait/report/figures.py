"""Figures drawn fast: Agg canvas, no pyplot state, fixed margins, one figure per file.

Constrained and tight layouts measure every text element (an extra draw per figure,
about 40 % of plotting time); here margins are fixed in inches, so a figure is drawn once,
when it is saved. ``--no-plots`` (batch use) turns plotting off through
:func:`plots_off`; workflows ask :func:`plots_wanted` before drawing.

Matplotlib is imported inside the functions, never at module import (CLI start-up).
"""

from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Iterator
from pathlib import Path

_PLOTS = contextvars.ContextVar("predgait_plots", default=True)
DPI = 110

#: Margins in inches: left, right, bottom, top (room for tick labels, axis labels, a title).
MARGINS = (0.75, 0.2, 0.55, 0.45)


def plots_wanted() -> bool:
    """False inside :func:`plots_off` (``--no-plots``)."""
    return _PLOTS.get()


@contextlib.contextmanager
def plots_off(off: bool = True) -> Iterator[None]:
    """Within the block, :func:`plots_wanted` is False (when ``off``)."""
    token = _PLOTS.set(not off and _PLOTS.get())
    try:
        yield
    finally:
        _PLOTS.reset(token)


def new_figure(nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float],
               sharex: bool = False, squeeze: bool = True, wspace: float = 0.35,
               hspace: float = 0.35, title: bool = False, legend_below: float = 0.0):
    """A figure on an Agg canvas with a grid of axes and fixed margins.

    Args:
        nrows: Rows of axes.
        ncols: Columns of axes.
        figsize: Width, height in inches.
        sharex: Share the x axis between rows.
        squeeze: As in ``plt.subplots``.
        wspace: Gap between columns, a fraction of the mean axes width.
        hspace: Gap between rows, a fraction of the mean axes height.
        title: Leave room for a figure title (``fig.suptitle``).
        legend_below: Inches left free at the bottom for a figure legend.

    Returns:
        (figure, axes).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, dpi=DPI)
    FigureCanvasAgg(fig)
    width, height = figsize
    left, right, bottom, top = MARGINS
    top += 0.3 if title else 0.0
    bottom += legend_below
    fig.subplots_adjust(left=left / width, right=1 - right / width, bottom=bottom / height,
                        top=1 - top / height, wspace=wspace, hspace=hspace)
    axes = fig.subplots(nrows, ncols, sharex=sharex, squeeze=squeeze)
    return fig, axes


def save_figure(fig, path: str | Path) -> Path:
    """Write ``fig`` as PNG (one draw) and release it.

    The PNG carries the figure's x-axis labels and its other labels as text chunks
    (:mod:`predgait.report.plot_labels`), read by the HTML report and its tests.
    """
    from predgait.report.plot_labels import figure_text

    path = Path(path)
    fig.savefig(path, dpi=DPI, metadata=figure_text(fig))
    fig.clear()
    return path
