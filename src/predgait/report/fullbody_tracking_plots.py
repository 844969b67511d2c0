"""Plots of a whole-body tracking solution: corrected vs measured angles, GRF vs plates."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from predgait.kinematics.clinical import clinical_joint

PANELS = ("hip_r_y", "knee_r_y", "ankle_r_y", "hip_l_y", "knee_l_y", "ankle_l_y")


def plot_tracking(model, data, solution, *, simulated=None):
    """Joint angles (deg) and vertical GRF (N): measured, corrected, re-simulated.

    Args:
        model: The whole body.
        data: The problem's TrackingData.
        solution: Its TrackingSolution.
        simulated: Optional (t, q) of the feedback re-simulation.

    Returns:
        The matplotlib figure.
    """
    from predgait.report.figures import new_figure

    names = list(model.joint_names)
    fig, axes = new_figure(4, 2, figsize=(9, 8), sharex=True, hspace=0.25,
                           legend_below=0.35)
    axes = axes.ravel()
    t = data.time
    for ax, joint in zip(axes[:6], PANELS, strict=True):
        i = 7 + names.index(joint)
        sign = clinical_joint(model.kind, joint)   # clinical angle and sign
        ax.plot(t, np.degrees(sign.clinical(data.q[:, i])), "k--", lw=1, label="measured (IK)")
        ax.plot(t, np.degrees(sign.clinical(solution.q[:, i])), "C0",
                label="dynamically consistent")
        if simulated is not None:
            ax.plot(simulated[0], np.degrees(sign.clinical(simulated[1][:, i])), "C1", lw=1,
                    label="re-simulated with feedback")
        ax.set_ylabel(f"{sign.angle.replace('_', ' ')} (deg)", fontsize=8)
    feet = solution.foot_forces()
    for j, (ax, side) in enumerate(zip(axes[6:], "rl", strict=True)):
        ax.plot(t, data.force[:, j, 2], "k--", lw=1)
        ax.plot(t, feet[:, j, 2], "C0")
        ax.set_ylabel(f"vertical GRF {side} (N)", fontsize=8)
        ax.set_xlabel("trial time (s)")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=8, frameon=False)
    return fig


def save_tracking_plots(folder: Path, model, data, solution, *, simulated=None) -> None:
    """``tracking.png`` and the stick figure / 3D viewer of the corrected motion.

    The viewer draws each foot's contact force (the sum over its sole points) at the
    centre of pressure of those points.
    """
    from predgait.problems.fullbody_tracking_stage import point_feet
    from predgait.report.figures import save_figure
    from predgait.report.viewer import contact_grf, write_motion

    save_figure(plot_tracking(model, data, solution, simulated=simulated),
                Path(folder) / "tracking.png")
    points = list(solution.points)
    feet = point_feet(solution.points)
    groups = [tuple(p for p, f in zip(points, feet, strict=True) if f == j) for j in (0, 1)]
    right, left = contact_grf(model, solution.q, solution.forces, points, groups)
    write_motion(folder, model, solution.time, solution.q, reference_q=data.q,
                 label="dynamically consistent",
                 grf={"right foot": right, "left foot": left})
