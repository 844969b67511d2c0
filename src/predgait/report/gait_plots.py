"""Plots of inverse-dynamics results against % gait cycle (Matplotlib, Agg-safe)."""

from __future__ import annotations

import numpy as np

from predgait.kinematics.clinical import ANGLES
from predgait.report.figures import new_figure, save_figure

LABELS = {"hip_flexion": "hip flexion", "knee_flexion": "knee flexion",
          "ankle_dorsiflexion": "ankle dorsiflexion"}


def cycle_axis(result) -> tuple[np.ndarray, np.ndarray, str]:
    """Selection mask and x values: % of the first gait cycle, or time if there is none."""
    cycle = result.first_cycle()
    if cycle is None:
        return np.ones(result.time.size, dtype=bool), result.time, "time (s)"
    start, stop = cycle
    mask = (result.time >= start - 1e-9) & (result.time <= stop + 1e-9)
    return mask, 100.0 * (result.time[mask] - start) / (stop - start), "% gait cycle"


def _toe_off_line(ax, result) -> None:
    cycle = result.first_cycle()
    if cycle is None:
        return
    start, stop = cycle
    for toe_off in result.events.toe_offs:
        if start < toe_off < stop:
            ax.axvline(100 * (toe_off - start) / (stop - start), color="0.6", ls=":", lw=1)


def plot_series(result, series: dict[str, np.ndarray], *, scale: float, ylabel: str,
                suffix: str, title: str):
    """One row of three panels (hip, knee, ankle); returns the figure."""
    mask, x, xlabel = cycle_axis(result)
    fig, axes = new_figure(1, 3, figsize=(12, 3.4), wspace=0.25, title=True)
    for ax, name in zip(axes, ANGLES, strict=True):
        ax.plot(x, scale * series[f"{name}{suffix}"][mask], color="#2a6f97", lw=1.8)
        ax.axhline(0, color="0.3", lw=0.6)
        _toe_off_line(ax, result)
        ax.set_title(LABELS[name])
        ax.set_xlabel(xlabel)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel(ylabel)
    fig.suptitle(f"{title} ({result.side} leg)")
    return fig


def save_gait_plots(result, folder) -> list[str]:
    """Write angles.png, moments.png, powers.png and grf.png; returns the file names."""
    mass = result.body_mass
    figures = {
        "angles.png": plot_series(result, result.anatomical_angles(), scale=180 / np.pi,
                                  ylabel="angle (deg)", suffix="", title="Joint angles"),
        "moments.png": plot_series(result, result.clinical_moments(), scale=1 / mass,
                                   ylabel="moment (N m/kg)", suffix="_moment",
                                   title="Joint moments (internal, + toward + angle)"),
        "powers.png": plot_series(result, result.powers(), scale=1 / mass,
                                  ylabel="power (W/kg)", suffix="_power", title="Joint powers"),
    }
    mask, x, xlabel = cycle_axis(result)
    fig, axes = new_figure(1, 2, figsize=(9, 3.4), wspace=0.3, title=True)
    for label, column in (("Fx (forward)", 0), ("Fz (vertical)", 2)):
        axes[0].plot(x, result.grf[mask, column] / (mass * 9.81), label=label)
    axes[0].set_ylabel("ground reaction (body weight)")
    axes[0].legend()
    stance = mask & (result.grf[:, 2] > 20)
    x_all = np.full(result.time.size, np.nan)
    x_all[mask] = x
    axes[1].plot(x_all[stance], result.cop[stance, 0], ".", ms=3)
    axes[1].set_ylabel("COP x (m, lab)")
    for ax in axes:
        ax.set_xlabel(xlabel)
        ax.grid(alpha=0.3)
    fig.suptitle("Ground reaction on the analysed foot")
    figures["grf.png"] = fig
    for name, figure in figures.items():
        save_figure(figure, f"{folder}/{name}")
    return list(figures)
