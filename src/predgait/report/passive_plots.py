"""Identified passive moment curves beside the literature's (passive knee and ankle fits)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

TITLES = {"knee": "knee flexion moment, passive elastic",
          "ankle": "ankle dorsiflexion moment, passive elastic"}
ANGLES = {"knee": "knee flexion (deg)", "ankle": "ankle dorsiflexion (deg)"}


def plot_literature(checks: dict, path: Path) -> Path:
    """One panel per joint: the identified elastic moment beside Riener & Edrich (1999).

    The identified moment with its 95 % band against the joint's clinical angle; the
    literature at each quiet sample's own hip, knee and ankle angles (dots: it depends on
    the adjacent joints, so it is no single curve).

    Args:
        checks: joint -> :class:`~predgait.problems.literature_check.LiteratureCheck`.
        path: PNG to write.

    Returns:
        ``path``.
    """
    from predgait.report.figures import new_figure, save_figure

    joints = list(checks)
    fig, axes = new_figure(1, len(joints), figsize=(5.2 * len(joints), 3.6), squeeze=False,
                           wspace=0.3)
    for ax, joint in zip(axes[0], joints, strict=True):
        check = checks[joint]
        order = np.argsort(check.angle)
        angle = np.degrees(check.angle[order])
        ax.fill_between(angle, (check.identified - check.band)[order],
                        (check.identified + check.band)[order], color="C0", alpha=0.25,
                        lw=0, label="identified, 95 % band")
        ax.plot(angle, check.identified[order], color="C0", lw=1.5, label="identified")
        ax.plot(np.degrees(check.angle), check.literature, ".", color="C3", ms=3,
                label="Riener & Edrich 1999 at this trial's angles")
        ax.axhline(0.0, color="0.5", lw=0.6)
        ax.set_title(TITLES[joint])
        ax.set_xlabel(ANGLES[joint])
        ax.set_ylabel("N m")
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=7)
    return save_figure(fig, path)
