"""Figure of a muscle-driven predicted stride: right-leg angles, vertical GRF, activations."""

from __future__ import annotations

from pathlib import Path

from predgait.kinematics.osim2d_angles import leg_angles_deg
from predgait.report.figures import new_figure, save_figure

#: Right-leg angles (kinematics.osim2d_angles) and their labels.
ANGLES = (("hip", "hip flexion (thigh vs trunk)"), ("knee", "knee flexion"),
          ("ankle", "ankle dorsiflexion"))


def save_muscle_gait_plots(path: Path, plant, planar, stride, *, measured=None) -> Path:
    """One PNG of the stride: angles, vertical GRF, activations.

    Right hip/knee/ankle (deg) with subject01 and Winter, vertical GRF per foot (BW),
    right-leg activations; x = % of the stride from right heel strike.

    Args:
        path: PNG file.
        plant: the muscle plant.
        planar: the OsimPlanarModel.
        stride: from right heel strike.
        measured: source -> joint -> (101,) deg (default: the human-likeness curves).
    """
    from predgait.analysis.human_likeness import PERCENT, measured_curves

    measured = measured_curves() if measured is None else measured
    cycle = 100.0 * (stride.t - stride.t[0]) / (stride.t[-1] - stride.t[0])
    angles = leg_angles_deg(planar, stride.q, "r")
    fig, axes = new_figure(1, 5, figsize=(22, 4.0), squeeze=False, wspace=0.3)
    axes = axes[0]
    for ax, (joint, label) in zip(axes[:3], ANGLES, strict=False):
        ax.plot(cycle, angles[joint], "k", lw=2, label="predicted")
        for source, curves in measured.items():
            ax.plot(PERCENT, curves[joint], "--", lw=1, label=source)
        ax.set_title(f"right {label}")
        ax.set_xlabel("% stride from right heel strike")
        ax.set_ylabel("deg")
    axes[0].legend(fontsize=8)
    weight = plant.model.total_mass() * plant.model.gravity
    fz = stride.foot_fz(plant)
    axes[3].plot(cycle, fz[:, 0] / weight, label="right")
    axes[3].plot(cycle, fz[:, 1] / weight, label="left")
    axes[3].set_title("vertical GRF")
    axes[3].set_ylabel("body weights")
    axes[3].set_xlabel("% stride")
    axes[3].legend(fontsize=8)
    for i, muscle in enumerate(plant.muscle_names):
        if muscle.endswith("_r"):
            axes[4].plot(cycle, stride.act[:, i], label=muscle[:-2])
    axes[4].set_title("right-leg activations")
    axes[4].set_ylim(0, 1)
    axes[4].set_xlabel("% stride")
    axes[4].legend(fontsize=7, ncol=2)
    return save_figure(fig, path)
