"""Active vs passive moment per joint over the gait cycle (passive decomposition fit)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

TITLES = {"knee": "knee flexion moment", "ankle": "ankle dorsiflexion moment"}


def plot_active_passive(samples, fit, joints, quiet_phases, path: Path, *,
                        stabilising=None) -> Path:
    """One panel per joint: measured, passive and active moment (N m) vs % gait cycle.

    Every gait cycle of the trial is drawn (a line per cycle); the quiet phases, where the
    fit takes the active moment as zero, are shaded.

    Args:
        samples: :class:`~predgait.problems.decomposition.GaitSamples`.
        fit: :class:`~predgait.problems.decomposition.Decomposition`.
        joints: Joints to draw.
        quiet_phases: [start, end) pairs, % gait cycle.
        path: PNG to write.
        stabilising: Optional joint -> (n,) moment of stabilising elements fitted by
            multiple shooting (:mod:`predgait.problems.shooting`) along the measured
            motion, N m, drawn beside the split.

    Returns:
        ``path``.
    """
    from predgait.report.figures import new_figure, save_figure

    fig, axes = new_figure(1, len(joints), figsize=(5.2 * len(joints), 3.6), squeeze=False,
                           wspace=0.3)
    cycles = np.unique(samples.cycle[samples.cycle >= 0])
    for ax, joint in zip(axes[0], joints, strict=True):
        for start, end in quiet_phases:
            ax.axvspan(start, end, color="0.9", zorder=0)
        series = (("inverse dynamics", samples.moments[joint], "k"),
                  ("passive (fitted)", fit.passive[joint], "C0"),
                  ("active = ID - passive", fit.active[joint], "C3"))
        if stabilising is not None:
            series += (("stabilising elements (shooting fit)", stabilising[joint], "C2"),)
        for label, values, colour in series:
            for i, cycle in enumerate(cycles):
                use = samples.cycle == cycle
                ax.plot(samples.percent[use], values[use], color=colour, lw=1.2,
                        alpha=0.8 if colour != "k" else 0.35,
                        label=label if i == 0 else None)
        ax.axhline(0.0, color="0.5", lw=0.6)
        ax.set_xlim(0, 100)
        ax.set_title(TITLES[joint])
        ax.set_xlabel("% gait cycle (shaded: quiet phases)")
        ax.set_ylabel("N m")
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=7)
    return save_figure(fig, path)
