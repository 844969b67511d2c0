"""Plot of whole-body re-synthesis runs (thesis 2.4).

Pelvis height and chosen joint angles, simulated (one colour per variant) against
measured, falls marked.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def plot_fullbody_runs(runs: Sequence, joint_names: Sequence[str],
                       panels: Sequence[str] = ("hip_r_y", "knee_r_y", "ankle_r_y",
                                                "ankle_l_x"), *, t0: float = 0.0):
    """Pelvis height (m) and joint angles (deg) over time, one panel each.

    Args:
        runs: :class:`~predgait.simulations.forward3d.Forward3DRun` objects.
        joint_names: The model's joint names (columns 7.. of q).
        panels: Joints to show.
        t0: s, subtracted from the time axis (the start of the runs).

    Returns:
        The matplotlib figure.
    """
    from predgait.report.figures import new_figure

    rows = (len(runs) + 2) // 2  # legend rows below the axes
    fig, axes = new_figure(len(panels) + 1, 1, figsize=(7, 2.0 * (len(panels) + 1)),
                           sharex=True, hspace=0.12, legend_below=0.3 + 0.17 * rows)
    longest = max(runs, key=lambda r: r.t[-1])
    for k, run in enumerate(runs):
        color = f"C{k}"
        t = run.t - t0
        series = [run.q[:, 2]] + [np.degrees(run.q[:, 7 + joint_names.index(j)])
                                  for j in panels]
        for ax, y in zip(axes, series, strict=True):
            ax.plot(t, y, color=color, label=run.mode.name)
            if run.time_to_fall is not None:
                ax.plot(t[-1], y[-1], "x", color=color, markersize=9, mew=2)
    t = longest.t - t0
    measured = [longest.measured[:, 2]] + [np.degrees(longest.measured[:, 7 + joint_names
                                                                         .index(j)])
                                           for j in panels]
    for ax, y, label in zip(axes, measured, ["pelvis height (m)",
                                             *[f"{j} (deg)" for j in panels]], strict=True):
        ax.plot(t, y, "k--", lw=1, label="measured")
        ax.set_ylabel(label, fontsize=8)
    axes[0].set_title("simulated vs measured; x = fall", fontsize=9)
    axes[-1].set_xlabel(f"time after start (s){f', start {t0:.3f} s' if t0 else ''}")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=7, frameon=False)
    return fig
