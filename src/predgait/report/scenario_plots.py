"""Plot of a what-if scenario: the edited leg against the baseline, angles and control."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from predgait.kinematics.clinical import LEG_FREE_JOINTS, clinical_joint
from predgait.report.figures import new_figure, save_figure


def save_scenario_plot(folder: Path, result) -> str:
    """angles.png: clinical angles (top) and PD feedback torques (bottom), both legs.

    Args:
        folder: Output folder.
        result: :class:`predgait.scenarios.run.ScenarioResult`.

    Returns:
        The file name.
    """
    fig, axes = new_figure(2, 2, figsize=(10, 6), wspace=0.25, hspace=0.35, sharex=True,
                           title=True)
    runs = ((result.baseline, result.feedback_baseline, "baseline", "#2a6f97"),
            (result.edited, result.feedback_edited, "edited", "#e07b00"))
    for column, name in enumerate(LEG_FREE_JOINTS):
        sign = clinical_joint("leg", name)  # q column 3 + column, feedback column column
        joint = sign.angle.replace("_", " ")
        top, bottom = axes[0, column], axes[1, column]
        for sim, feedback, label, colour in runs:
            top.plot(sim.t, np.degrees(sign.clinical(sim.q[:, 3 + column])), color=colour,
                     label=label)
            bottom.plot(sim.t, sign.clinical(feedback[:, column]), color=colour, label=label)
            if sim.time_to_fall is not None:
                top.axvline(sim.time_to_fall, color=colour, ls="--", lw=1)
        top.set_title(f"{joint} (deg)", fontsize=10)
        bottom.set_title(f"PD feedback torque toward the measured motion, {joint} "
                         "(N m)", fontsize=9)
        bottom.axhline(0.0, color="0.4", lw=0.5)
        bottom.set_xlabel("time from heel strike (s)")
        for ax in (top, bottom):
            ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"Scenario '{result.spec.name}': edited leg vs baseline, same drive and "
                 "control", fontsize=11)
    save_figure(fig, Path(folder) / "angles.png")
    return "angles.png"
