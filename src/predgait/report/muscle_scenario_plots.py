"""Figure of a muscle-driven scenario: baseline vs edited gait, each leg from its heel strike."""

from __future__ import annotations

from pathlib import Path

from predgait.report.figures import new_figure, save_figure

#: Panels: curve key of leg_measures, y label.
PANELS = (("hip", "hip flexion (deg)"), ("knee", "knee flexion (deg)"),
          ("ankle", "ankle dorsiflexion (deg)"), ("grf", "vertical GRF (BW)"))


def save_muscle_scenario_plot(path: Path, baseline, edited, *, title: str = "") -> Path:
    """One PNG: rows right and left leg; hip, knee, ankle angles and vertical GRF.

    Args:
        path: PNG file.
        baseline: MusclePrediction of the unedited model.
        edited: MusclePrediction of the edited model.
        title: the scenario's name.
    """
    from predgait.analysis.human_likeness import PERCENT
    from predgait.scenarios.muscle_scenario_compare import leg_measures

    fig, axes = new_figure(2, 4, figsize=(18, 7.0), squeeze=False, wspace=0.3, hspace=0.35,
                           title=bool(title))
    for row, (side, leg) in enumerate((("r", "right"), ("l", "left"))):
        for pred, style, label in ((baseline, "k--", "baseline"), (edited, "C3", "edited")):
            m = leg_measures(pred.stride, pred.plant, pred.planar, side)
            for ax, (key, ylabel) in zip(axes[row], PANELS, strict=True):
                y = m["vertical_grf_bw"] if key == "grf" else m["curves"][key]
                ax.plot(PERCENT, y, style, lw=2, label=label)
                ax.set_ylabel(ylabel)
                ax.set_xlabel(f"% stride from {leg} heel strike")
        axes[row][0].legend(loc="best", fontsize=8)
    if title:
        fig.suptitle(title)
    return save_figure(fig, path)
