"""Plots of an optimisation: measured vs synthesized angles, original vs corrected moments."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from predgait.report.figures import new_figure, save_figure

JOINTS = (("ankle dorsiflexion", 3, 1.0), ("knee flexion", 4, -1.0))


def save_solve_plots(folder: Path, inverse, fit, sim, drivers, *, threshold_deg: float,
                     time_to_threshold: float | None = None) -> None:
    """angles.png (measured, optimised, Pinocchio re-simulation), deviation.png, moments.png.

    deviation.png: the re-simulation with the optimised inputs minus the measured motion,
    the ``threshold_deg`` band shaded, where it leaves the band and the fall marked.
    """
    from predgait.report.raster import save_chart
    from predgait.report.simulation_plots import deviation_panel

    save_chart(folder / "deviation.png",
               [deviation_panel(sim.t, sim.q[:, 3:], (inverse.time, inverse.q[:, 3:]),
                                ("ankle", "knee"), threshold_deg=threshold_deg,
                                time_to_threshold=time_to_threshold,
                                time_to_fall=sim.time_to_fall)],
               size=(7, 3.8), title="Deviation from the measured motion")
    fig, axes = new_figure(1, 2, figsize=(10, 3.6), wspace=0.25, title=True)
    window = (inverse.time >= fit.t[0]) & (inverse.time <= fit.t[-1])
    for ax, (name, i, sign) in zip(axes, JOINTS, strict=True):
        ax.plot(inverse.time[window], np.degrees(sign * inverse.q[window, i]), "k", lw=3,
                alpha=0.3, label="measured")
        ax.plot(fit.t, np.degrees(sign * fit.x[:, i - 3]), label="optimised (collocation)")
        ax.plot(sim.t, np.degrees(sign * sim.q[:, i]), "--", label="re-simulated (Pinocchio)")
        ax.set_title(name)
        ax.set_xlabel("time from heel strike (s)")
        ax.set_ylabel("deg")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"{fit.kind.replace('_', ' ')}")
    save_figure(fig, folder / "angles.png")
    if fit.torque_change is None:
        return
    original = np.array([drivers.joint_torque(t) for t in fit.t])
    fig, axes = new_figure(1, 2, figsize=(10, 3.6), wspace=0.25, title=True)
    for ax, (name, i, sign) in zip(axes, JOINTS, strict=True):
        ax.plot(fit.t, sign * original[:, i - 3], label="inverse dynamics")
        ax.plot(fit.t, sign * (original[:, i - 3] + fit.torque_change[:, i - 3]), "--",
                label="corrected")
        ax.set_title(f"{name} moment")
        ax.set_xlabel("time from heel strike (s)")
        ax.set_ylabel("N m")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    save_figure(fig, folder / "moments.png")
