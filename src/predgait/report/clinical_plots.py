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

from predgait.report.raster import Line, Panel, save_chart

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


def left_right_panels(time, series: Mapping[str, np.ndarray], cycles, *, suffix: str,
                      scale: float, ylabel: str) -> list[Panel]:
    """The 2 x 3 :data:`PANELS`, both sides overlaid.

    Args:
        time: (n,) s.
        series: Clinical name with side (``hip_flexion_l`` + ``suffix``) -> (n,) values.
        cycles: :func:`side_cycles`; a side without a full cycle is drawn over time.
        suffix: ``""`` for angles, ``"_moment"`` for moments.
        scale: Factor applied to the values (e.g. 1 / body mass).
        ylabel: Unit label.
    """
    over_time = any(side not in cycles for side in SIDES)
    panels = []
    for k, panel in enumerate(PANELS):
        lines = []
        for side, (label, colour) in SIDES.items():
            values = series.get(f"{panel}_{side}{suffix}")
            if values is None:
                continue
            legend = k == 0
            if side in cycles:
                mask, x = _percent(time, cycles[side])
                lines.append(Line(x, scale * values[mask], color=colour, width=1.6,
                                  label=label if legend else None))
            else:
                lines.append(Line(time, scale * values, color=colour, width=0.8,
                                  label=f"{label} (time, s)" if legend else None))
        panels.append(Panel(tuple(lines), title=panel.replace("_", " "),
                            xlabel=("% gait cycle" + (" (or time, s)" if over_time else ""))
                            if k >= 3 else "", ylabel=ylabel if k % 3 == 0 else "",
                            hlines=(0.0,)))
    return panels


def save_clinical_plots(folder: Path, time, angles, moments, stances, *,
                        body_mass: float) -> list[str]:
    """clinical_angles.png (deg) and clinical_moments.png (N m/kg); their names."""
    time = np.asarray(time)
    cycles = side_cycles(time, stances)
    note = " - no normal band (no shippable normative data set)"
    figures = {
        "clinical_angles.png": (left_right_panels(time, angles, cycles, suffix="", scale=1.0,
                                                  ylabel="angle (deg)"),
                                "Joint angles, left and right" + note),
        "clinical_moments.png": (left_right_panels(time, moments, cycles, suffix="_moment",
                                                   scale=1.0 / body_mass,
                                                   ylabel="moment (N m/kg)"),
                                 "Internal joint moments, left and right" + note),
    }
    for name, (panels, title) in figures.items():
        save_chart(Path(folder) / name, panels, size=(12, 6.2), title=title, columns=3,
                   wspace=0.28, hspace=0.45)
    return list(figures)
