"""Plot of a ``torque_feedback`` solve: angles held by feedback, and the torque split."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from predgait.kinematics.clinical import LEG_FREE_JOINTS, clinical_joint
from predgait.report.figures import new_figure, save_figure


def save_feedback_plot(path: Path, result: dict, threshold_deg: float) -> Path:
    """Angles and moments of a torque_feedback solve per joint, clinical signs.

    Angles: measured, re-simulated with and without feedback. Moments: feedforward,
    feedback and the inverse-dynamics band over the cut-offs.

    Args:
        path: PNG to write.
        result: What :func:`predgait.workflows.torque_feedback.solve_feedback` returns.
        threshold_deg: The deviation threshold, deg (shaded around the measured angle).
    """
    inverse, sim, open_sim, t = result["inverse"], result["sim"], result["open_sim"], result["t"]
    lo, hi = result["window"]
    inside = (inverse.time >= lo) & (inverse.time <= hi)
    fig, axes = new_figure(2, 2, figsize=(10, 6.4), sharex=True, wspace=0.25, title=True)
    for col, joint in enumerate(LEG_FREE_JOINTS):
        row, sign = 3 + col, clinical_joint("leg", joint)
        name = sign.angle.replace("_", " ")
        ax = axes[0, col]
        measured = np.degrees(sign.clinical(inverse.q[inside, row]))
        ax.fill_between(inverse.time[inside], measured - threshold_deg,
                        measured + threshold_deg, color="0.85", label=f"+-{threshold_deg:g} deg")
        ax.plot(inverse.time[inside], measured, "k", lw=2, label="measured")
        ax.plot(open_sim.t, np.degrees(sign.clinical(open_sim.q[:, row])), "C3--",
                label="without feedback")
        ax.plot(sim.t, np.degrees(sign.clinical(sim.q[:, row])), "C0", label="with LQR feedback")
        ax.set_ylim(measured.min() - 15, measured.max() + 15)
        ax.set_title(f"{name} angle, deg")
        ax = axes[1, col]
        band = sign.clinical(result["band"][:, :, col])
        ax.fill_between(t, band.min(axis=0), band.max(axis=0), color="0.8",
                        label="inverse dynamics, cut-offs")
        ax.plot(t, sign.clinical(result["feedforward"][:, col]), "k", lw=1.5,
                label="feedforward")
        ax.plot(t, sign.clinical(result["feedback"][:, col]), "C0", label="feedback")
        ax.set_title(f"{name} moment, N m")
        ax.set_xlabel("time from heel strike, s")
    axes[0, 0].legend(fontsize=7, loc="best")
    axes[1, 0].legend(fontsize=7, loc="best")
    fig.suptitle("Feedforward torques plus time-varying LQR feedback (forward re-simulation)")
    return save_figure(fig, path)
