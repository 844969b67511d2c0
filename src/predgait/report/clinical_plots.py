"""Clinical gait curves of the whole body: left and right over % of their own gait cycle.

Each side is normalised from one of its heel strikes (the start of a stance) to the
next, the usual clinical presentation; right in green, left in red (the common gait-lab
convention). No normal band is drawn: no normative data set whose licence allows
shipping it with predgait is bundled, so the curves are shown without one.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from predgait.report.figures import new_figure, save_figure

#: Panels (clinical names without the side suffix).
PANELS = ("hip_flexion", "hip_adduction", "hip_internal_rotation", "knee_flexion",
          "ankle_dorsiflexion", "ankle_inversion")
SIDES = {"r": ("right", "#1b9e3a"), "l": ("left", "#d62728")}


def side_cycles(time: np.ndarray, stances: Sequence[Mapping]) -> dict[str, tuple[float, float]]:
    """Per side ("r", "l"), the first full cycle (heel strike to heel strike), s.

    A stance starting at the first sample is not a heel strike (the trial began in
    stance) and is skipped.
    """
    cycles = {}
    for side in SIDES:
        strikes = sorted(s["start"] for s in stances
                         if s["side"] == side and s["start"] > time[0] + 1e-9)
        if len(strikes) >= 2:
            cycles[side] = (strikes[0], strikes[1])
    return cycles


def _percent(time, cycle):
    mask = (time >= cycle[0] - 1e-9) & (time <= cycle[1] + 1e-9)
    return mask, 100.0 * (time[mask] - cycle[0]) / (cycle[1] - cycle[0])


def plot_left_right(time, series: Mapping[str, np.ndarray], cycles, *, suffix: str,
                    scale: float, ylabel: str, title: str):
    """A 2 x 3 grid of :data:`PANELS`, both sides overlaid; returns the figure.

    Args:
        time: (n,) s.
        series: Clinical name with side (``hip_flexion_l`` + ``suffix``) -> (n,) values.
        cycles: :func:`side_cycles`; a side without a full cycle is drawn over time.
        suffix: ``""`` for angles, ``"_moment"`` for moments.
        scale: Factor applied to the values (e.g. 1 / body mass).
        ylabel: Unit label.
        title: Figure title.
    """
    fig, axes = new_figure(2, 3, figsize=(12, 6.2), wspace=0.28, hspace=0.45, title=True)
    over_time = any(side not in cycles for side in SIDES)
    for ax, panel in zip(axes.ravel(), PANELS, strict=True):
        for side, (label, colour) in SIDES.items():
            values = series.get(f"{panel}_{side}{suffix}")
            if values is None:
                continue
            if side in cycles:
                mask, x = _percent(time, cycles[side])
                ax.plot(x, scale * values[mask], color=colour, lw=1.6, label=label)
            else:
                ax.plot(time, scale * values, color=colour, lw=1.0, ls="--",
                        label=f"{label} (time, s)")
        ax.axhline(0.0, color="0.4", lw=0.5)
        ax.set_title(panel.replace("_", " "), fontsize=10)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("% gait cycle" + (" (or time, s)" if over_time else ""))
    for ax in axes[:, 0]:
        ax.set_ylabel(ylabel)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"{title} — no normal band (no shippable normative data set)", fontsize=11)
    return fig


def save_clinical_plots(folder: Path, time, angles, moments, stances, *,
                        body_mass: float) -> list[str]:
    """clinical_angles.png (deg) and clinical_moments.png (N m/kg); their names."""
    time = np.asarray(time)
    cycles = side_cycles(time, stances)
    figures = {
        "clinical_angles.png": plot_left_right(time, angles, cycles, suffix="", scale=1.0,
                                               ylabel="angle (deg)",
                                               title="Joint angles, left and right"),
        "clinical_moments.png": plot_left_right(
            time, moments, cycles, suffix="_moment", scale=1.0 / body_mass,
            ylabel="moment (N m/kg)", title="Internal joint moments, left and right"),
    }
    for name, fig in figures.items():
        save_figure(fig, Path(folder) / name)
    return list(figures)
