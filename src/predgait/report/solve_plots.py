"""Plots of an optimisation: measured vs synthesized angles, original vs corrected moments."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from predgait.kinematics.clinical import LEG_FREE_JOINTS
from predgait.report.diagnostics import plot_angles, plot_moments
from predgait.report.figures import new_figure, save_figure


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
    for ax, joint in zip(axes, LEG_FREE_JOINTS, strict=True):
        plot_angles(joint, inverse.time, inverse.q, fit=fit,
                    simulations={"re-simulated (Pinocchio)": sim}, ax=ax)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"{fit.kind.replace('_', ' ')}")
    save_figure(fig, folder / "angles.png")
    if fit.torque_change is None:
        return
    original = np.array([drivers.joint_torque(t) for t in fit.t])
    fig, axes = new_figure(1, 2, figsize=(10, 3.6), wspace=0.25, title=True)
    for ax, joint in zip(axes, LEG_FREE_JOINTS, strict=True):
        plot_moments(joint, fit.t, original, fit.torque_change, ax=ax)
    axes[0].legend(fontsize=8)
    save_figure(fig, folder / "moments.png")
