"""Plots of a scenario sweep: heat maps over a two-parameter grid, else outcome vs parameter.

The scenario file's own setting (the sweep's baseline) is marked with a white star on the
heat maps and a dashed line on the outcome plots, when it lies in the swept range.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from predgait.report.figures import new_figure, save_figure
from predgait.report.tidy import label_of, unit_of


def _metric_label(metric: str) -> str:
    unit = unit_of(metric)
    return f"{label_of(metric)} ({unit[0]})" if unit else label_of(metric)


def _heatmaps(ok, params, metrics, folder: Path, baseline) -> list[str] | None:
    xs = sorted({o.point.values[params[0]] for o in ok})
    ys = sorted({o.point.values[params[1]] for o in ok})
    if len(xs) * len(ys) != len(ok):
        return None
    written = []
    for metric in metrics:
        grid = np.full((len(ys), len(xs)), np.nan)
        for o in ok:
            grid[ys.index(o.point.values[params[1]]),
                 xs.index(o.point.values[params[0]])] = o.metrics.get(metric, np.nan)
        fig, ax = new_figure(figsize=(6.0, 4.2))
        image = ax.imshow(grid, origin="lower", aspect="auto", cmap="viridis")
        for (row, col), value in np.ndenumerate(grid):
            ax.text(col, row, f"{value:.3g}", ha="center", va="center", fontsize=7,
                    color="white" if value < np.nanmean(grid) else "black")
        ax.set_xticks(range(len(xs)), [f"{x:g}" for x in xs])
        ax.set_yticks(range(len(ys)), [f"{y:g}" for y in ys])
        ax.set_xlabel(params[0])
        ax.set_ylabel(params[1])
        base = [baseline.get(p) for p in params]
        if all(b is not None for b in base):
            bx = np.interp(base[0], xs, range(len(xs)))
            by = np.interp(base[1], ys, range(len(ys)))
            ax.plot(bx, by, "*", ms=16, mfc="none", mec="red", mew=1.5)
        ax.set_title(_metric_label(metric) + ("; red star: scenario file setting"
                                              if all(b is not None for b in base) else ""),
                     fontsize=9)
        fig.colorbar(image, ax=ax, label=_metric_label(metric))
        name = f"heatmap_{metric}.png"
        save_figure(fig, folder / name)
        written.append(name)
    return written


def save_sweep_plots(outcomes: Sequence, folder: Path, metrics: Sequence[str], *,
                     baseline: Mapping[str, float] | None = None) -> list[str]:
    """Write the sweep's plots into ``folder``; returns their names.

    Args:
        outcomes: Sweep outcomes (``.ok``, ``.point.values`` {key: value}, ``.metrics``).
        folder: Output folder.
        metrics: Metric names to plot (keys of ``.metrics``, unit-suffixed).
        baseline: The scenario file's value of each swept key, marked on the plots.
    """
    baseline = dict(baseline or {})
    ok = [o for o in outcomes if o.ok]
    if not ok:
        return []
    params = list(ok[0].point.values)
    if len(params) == 2 and len(ok) == len(outcomes):
        written = _heatmaps(ok, params, metrics, folder, baseline)
        if written is not None:
            return written
    written = []
    for param in params:
        fig, axes = new_figure(1, len(metrics), figsize=(12, 3.4), wspace=0.35, squeeze=False)
        x = [o.point.values[param] for o in ok]
        for ax, metric in zip(axes[0], metrics, strict=True):
            ax.plot(x, [o.metrics.get(metric, np.nan) for o in ok], "o")
            if baseline.get(param) is not None:
                ax.axvline(baseline[param], color="red", ls="--", lw=1,
                           label="scenario file setting")
            ax.set_xlabel(param)
            ax.set_title(_metric_label(metric), fontsize=9)
            ax.grid(alpha=0.3)
        if baseline.get(param) is not None:
            axes[0][0].legend(fontsize=7)
        name = f"outcome_vs_{param.replace('.', '_')}.png"
        save_figure(fig, folder / name)
        written.append(name)
    return written
