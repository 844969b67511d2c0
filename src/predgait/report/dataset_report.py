"""The dataset report page of ``predgait batch``: small multiples and the trials' status.

One figure per variable (``curves_<analysis>_<variable>.png``, one panel per subject,
condition and side): every cycle thin (grey; flagged cycles red), the mean +- SD over the
cycles that are not flagged (blue), and a normative band (mean +- SD, light grey) under
them when given. ``report.html`` embeds them (one offline file, the style of
:mod:`predgait.report.html`) above a table of every trial's status.
"""

from __future__ import annotations

import base64
from collections import defaultdict
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from predgait import __version__
from predgait.report.dataset_tables import ALL, PERCENT
from predgait.report.figures import plots_wanted
from predgait.report.html import _STYLE, _esc
from predgait.report.raster import Line, Panel, save_chart

GREY, RED, BLUE, NORM = "#b0b0b0", "#d62728", "#2a6f97", "#d9d9d9"


def _panels(cycles: Mapping[tuple, dict], curves: Mapping[tuple, tuple], band, unit: str):
    panels = []
    for group in sorted(cycles):
        lines = []
        if band is not None:
            percent, mean, sd = band
            lines += [Line(percent, mean - sd, color=NORM, width=1.0),
                      Line(percent, mean + sd, color=NORM, width=1.0),
                      Line(percent, mean, color=NORM, width=2.0)]
        for values, flagged in cycles[group].values():
            lines.append(Line(PERCENT, values, color=RED if flagged else GREY, width=0.7))
        if group in curves:
            mean, sd = curves[group]
            lines += [Line(PERCENT, mean - sd, color=BLUE, width=0.8),
                      Line(PERCENT, mean + sd, color=BLUE, width=0.8),
                      Line(PERCENT, mean, color=BLUE, width=2.0)]
        subject, condition, side = group
        panels.append(Panel(tuple(lines), title=f"{subject}, {condition}, {side}",
                            xlabel="% gait cycle", ylabel=unit, hlines=(0.0,)))
    return panels


def save_figures(folder: Path, cycles: Sequence, curves: Sequence[Sequence],
                 bands: Mapping | None = None) -> list[Path]:
    """The small-multiples PNGs (see the module docstring); returns their paths.

    ``cycles``: :class:`predgait.report.dataset_tables.Cycle`; ``curves``: rows of
    :func:`predgait.report.dataset_tables.mean_curves`.
    """
    cycles_by: dict = defaultdict(lambda: defaultdict(dict))
    units = {}
    for c in cycles:
        subject, condition, trial, analysis, side = c.key
        figure = (analysis, c.variable)
        units[figure] = c.unit
        cycles_by[figure][(subject, condition, side)][(trial, c.cycle)] = (c.values, c.flagged)
    means: dict = defaultdict(dict)
    collected: dict = defaultdict(lambda: (np.full(PERCENT.size, np.nan),
                                           np.full(PERCENT.size, np.nan)))
    for subject, condition, analysis, side, variable, _, percent, mean, sd, _ in curves:
        if subject != ALL:
            arrays = collected[(analysis, variable, subject, condition, side)]
            arrays[0][percent], arrays[1][percent] = mean, sd
    for (analysis, variable, *group), arrays in collected.items():
        means[(analysis, variable)][tuple(group)] = arrays
    paths = []
    for figure in sorted(cycles_by):
        analysis, variable = figure
        band = (bands or {}).get(variable)
        panels = _panels(cycles_by[figure], means[figure], band, units[figure])
        columns = min(len(panels), 3)
        rows_needed = -(-len(panels) // columns)
        path = folder / f"curves_{analysis}_{variable}.png"
        save_chart(path, panels, size=(3.2 * columns + 0.6, 2.6 * rows_needed + 0.6),
                   title=f"{variable.replace('_', ' ')} ({analysis})", columns=columns)
        paths.append(path)
    return paths


def write_report(folder: Path, name: str, status: Sequence[Mapping], cycles: Sequence,
                 curves: Sequence[Sequence], bands: Mapping | None = None) -> Path:
    """Write the figures and ``report.html`` into ``folder``; returns the page's path."""
    figures = save_figures(folder, cycles, curves, bands) if plots_wanted() else []
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    counts = defaultdict(int)
    for row in status:
        counts[row["status"]] += 1
    head = ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
    cells = "".join(
        "<tr>" + "".join(f"<td>{_esc(row[k])}</td>" for k in
                         ("trial", "subject", "condition", "status", "cycles",
                          "flagged_frames", "reason")) + "</tr>" for row in status)
    images = "".join(
        f"<figure><img alt='{_esc(p.stem)}' src='data:image/png;base64,"
        f"{base64.b64encode(p.read_bytes()).decode()}'><figcaption>{_esc(p.stem)}: cycles "
        "grey (flagged red), mean +- SD blue" + (", normative band light grey" if bands else "")
        + "</figcaption></figure>" for p in figures)
    title = f"predgait batch: {name}"
    page = ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<title>{_esc(title)}</title><style>{_STYLE}</style></head><body>"
            f"<h1>{_esc(title)}</h1><p class='meta'>predgait {__version__}, {stamp}. "
            f"{len(status)} trials: {_esc(head)}.</p>"
            "<h2>Curves over the gait cycle</h2><div class='figures'>" + images + "</div>"
            "<h2>Trials</h2><table><tr><th>trial</th><th>subject</th><th>condition</th>"
            "<th>status</th><th>cycles</th><th>flagged frames</th><th>reason</th></tr>"
            + cells + "</table></body></html>\n")
    path = folder / "report.html"
    path.write_text(page, encoding="utf-8")
    return path
