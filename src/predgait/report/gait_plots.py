"""Plots of inverse-dynamics results against % gait cycle (Pillow line charts, no Matplotlib)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from predgait.kinematics.clinical import ANGLES
from predgait.report.raster import Line, Panel, save_chart

LABELS = {"hip_flexion": "hip flexion", "knee_flexion": "knee flexion",
          "ankle_dorsiflexion": "ankle dorsiflexion"}
BLUE = "#2a6f97"


def cycle_axis(result) -> tuple[np.ndarray, np.ndarray, str]:
    """Selection mask and x values: % of the first gait cycle, or time if there is none."""
    cycle = result.first_cycle()
    if cycle is None:
        return np.ones(result.time.size, dtype=bool), result.time, "trial time (s)"
    start, stop = cycle
    mask = (result.time >= start - 1e-9) & (result.time <= stop + 1e-9)
    return mask, 100.0 * (result.time[mask] - start) / (stop - start), "% gait cycle"


def toe_offs(result) -> tuple[float, ...]:
    """Toe offs within the first gait cycle, % of the cycle (none without a cycle)."""
    cycle = result.first_cycle()
    if cycle is None:
        return ()
    start, stop = cycle
    return tuple(100 * (t - start) / (stop - start) for t in result.events.toe_offs
                 if start < t < stop)


def series_panels(result, series: dict[str, np.ndarray], *, scale: float, ylabel: str,
                  suffix: str) -> list[Panel]:
    """Three panels (hip, knee, ankle) of one kind of series against the gait cycle."""
    mask, x, xlabel = cycle_axis(result)
    return [Panel((Line(x, scale * series[f"{name}{suffix}"][mask], color=BLUE, width=1.8),),
                  title=LABELS[name], xlabel=xlabel, ylabel=ylabel if name == ANGLES[0] else "",
                  hlines=(0.0,), vlines=toe_offs(result))
            for name in ANGLES]


def grf_panels(result) -> list[Panel]:
    """Ground reaction (body weights) and the COP's forward position in stance."""
    mass = result.body_mass
    mask, x, xlabel = cycle_axis(result)
    forces = tuple(Line(x, result.grf[mask, column] / (mass * 9.81), color=color, label=label)
                   for label, column, color in (("Fx (forward)", 0, "#1f77b4"),
                                                ("Fz (vertical)", 2, "#ff7f0e")))
    stance = mask & (result.grf[:, 2] > 20)
    x_all = np.full(result.time.size, np.nan)
    x_all[mask] = x
    cop = Line(x_all[stance], result.cop[stance, 0], width=0.0, dots=3.0)
    return [Panel(forces, xlabel=xlabel, ylabel="ground reaction (body weight)"),
            Panel((cop,), xlabel=xlabel, ylabel="COP x (m, lab)")]


def save_gait_plots(result, folder) -> list[str]:
    """Write angles.png, moments.png, powers.png and grf.png; returns the file names."""
    mass, side = result.body_mass, f"({result.side} leg)"
    folder = Path(folder)
    figures = {
        "angles.png": (series_panels(result, result.anatomical_angles(), scale=180 / np.pi,
                                     ylabel="angle (deg)", suffix=""),
                       f"Joint angles {side}"),
        "moments.png": (series_panels(result, result.clinical_moments(), scale=1 / mass,
                                      ylabel="moment (N m/kg)", suffix="_moment"),
                        f"Joint moments (internal, + toward + angle) {side}"),
        "powers.png": (series_panels(result, result.powers(), scale=1 / mass,
                                     ylabel="power (W/kg)", suffix="_power"),
                       f"Joint powers {side}"),
    }
    for name, (panels, title) in figures.items():
        save_chart(folder / name, panels, size=(12, 3.4), title=title, wspace=0.25)
    save_chart(folder / "grf.png", grf_panels(result), size=(9, 3.4),
               title="Ground reaction on the analysed foot", wspace=0.3)
    return [*figures, "grf.png"]
