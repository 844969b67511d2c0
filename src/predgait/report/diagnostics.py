"""Diagnostic plots of an optimisation (each takes ``ax=None`` and returns the axes).

* :func:`plot_history`: objective and constraint violation per Ipopt iteration.
* :func:`plot_angles`: measured joint angle vs the optimised (collocation) motion and any
  number of Pinocchio re-simulations (e.g. before = uncorrected moments, after = fit).
* :func:`plot_moments`: original vs corrected joint moment (torque correction).
* :func:`ipopt_lines`: the Ipopt history as short text lines, one per ``every`` iterations.

Angles and moments are shown in clinical convention (ankle dorsiflexion = q_ankle, knee
flexion = -q_knee; moments likewise), see :mod:`predgait.kinematics.clinical`.
"""

from __future__ import annotations

import numpy as np

from predgait.kinematics.clinical import LEG_FREE_JOINTS, clinical_joint
from predgait.report.figures import new_figure, save_figure

#: Lowest value drawn on a log axis: machine precision (double).
FLOOR = float(np.finfo(float).eps)
#: Free joint -> (column in the full coordinates, column in the free state).
JOINTS = {joint: (3 + i, i) for i, joint in enumerate(LEG_FREE_JOINTS)}


def _axes(ax):
    if ax is None:
        _, ax = new_figure(figsize=(5, 3.4))
    return ax


def plot_history(solved, axes=None):
    """Objective and infeasibility per Ipopt iteration, each on its own labelled log axis.

    Top: |objective| (its sign in the legend when it goes negative). Bottom: the primal
    infeasibility (constraint violation, inf_pr) and the dual infeasibility (inf_du). Values
    below :data:`FLOOR` (machine precision, ~2.2e-16) are drawn at it: an exact zero would
    stretch a log axis down to 1e-300.

    Args:
        solved: A :class:`predgait.problems.collocation.Solved` (its ``history``).
        axes: Two axes (top, bottom) to draw on; None makes a figure.

    Returns:
        The two axes.
    """
    if axes is None:
        _, axes = new_figure(2, 1, figsize=(6, 5.2), sharex=True, hspace=0.3, title=True)
    top, bottom = axes
    history = solved.history
    objective = np.asarray(history.get("objective", ()), dtype=float)
    iterations = np.arange(objective.size)
    negative = bool(np.any(objective < 0))
    top.semilogy(iterations, np.maximum(np.abs(objective), FLOOR), "C0.-",
                 label="|objective| (negative values occur)" if negative else "objective")
    top.set_ylabel("objective")
    for key, style, label in (("constraint_violation", "C3.-", "primal infeasibility (inf_pr)"),
                              ("dual_infeasibility", "C2.--", "dual infeasibility (inf_du)")):
        values = np.asarray(history.get(key, ()), dtype=float)
        if values.size:
            bottom.semilogy(np.arange(values.size), np.maximum(values, FLOOR), style,
                            label=label)
    bottom.set_ylabel("infeasibility")
    bottom.set_xlabel("Ipopt iteration")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.set_ylim(bottom=FLOOR / 3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, loc="upper right")
    top.figure.suptitle(f"Ipopt: {solved.status}, {solved.iterations} iterations, "
                        f"{solved.seconds * 1e3:.0f} ms (values below {FLOOR:.1e} drawn "
                        "at it)", fontsize=9)
    return axes


def plot_angles(joint: str, measured_t, measured_q, *, fit=None, simulations=None,
                ax=None):
    """One joint's clinical angle (deg): measured, optimised and re-simulated.

    Args:
        joint: ``ankle`` or ``knee``.
        measured_t: (n,) s.
        measured_q: (n, nq) model coordinates, rad.
        fit: Optional :class:`predgait.problems.fitting.FitResult` (its states).
        simulations: Optional label -> SimulationResult (``t``, ``q`` (m, nq)).
        ax: Axes to draw on; None makes a figure.

    Returns:
        The axes.
    """
    ax = _axes(ax)
    (full, free), sign = JOINTS[joint], clinical_joint("leg", joint)
    t = np.asarray(measured_t)
    if fit is not None:
        keep = (t >= fit.t[0] - 1e-9) & (t <= fit.t[-1] + 1e-9)
        t, measured_q = t[keep], np.asarray(measured_q)[keep]
    measured = np.degrees(sign.clinical(np.asarray(measured_q)[:, full]))
    ax.plot(t, measured, "k", lw=3, alpha=0.3, label="measured")
    if fit is not None:
        ax.plot(fit.t, np.degrees(sign.clinical(fit.x[:, free])), label="optimised (collocation)")
    for i, (label, sim) in enumerate((simulations or {}).items()):
        ax.plot(sim.t, np.degrees(sign.clinical(sim.q[:, full])), "--", color=f"C{i + 1}",
                label=label)
    lo, hi = measured.min(), measured.max()
    ax.set_ylim(lo - 0.5 * (hi - lo) - 5, hi + 0.5 * (hi - lo) + 5)
    ax.set_title(sign.angle.replace("_", " "))
    ax.set_xlabel("time from heel strike (s)")
    ax.set_ylabel("deg")
    ax.grid(alpha=0.3)
    return ax


def plot_moments(joint: str, t, original, change, ax=None):
    """Original vs corrected clinical moment of one joint, N m.

    Args:
        joint: ``ankle`` or ``knee``.
        t: (n,) s grid of the correction.
        original: (n, 2) ankle, knee torques, N m, model sign.
        change: (n, 2) their fitted changes, N m, model sign.
        ax: Axes to draw on; None makes a figure.

    Returns:
        The axes.
    """
    ax = _axes(ax)
    (_, free), sign = JOINTS[joint], clinical_joint("leg", joint)
    ax.plot(t, sign.clinical(original[:, free]), label="inverse dynamics")
    ax.plot(t, sign.clinical(original[:, free] + change[:, free]), "--", label="corrected")
    ax.set_title(f"{sign.angle.replace('_', ' ')} moment")
    ax.set_xlabel("time from heel strike (s)")
    ax.set_ylabel("N m")
    ax.grid(alpha=0.3)
    return ax


def ipopt_lines(solved, *, every: int = 5) -> list[str]:
    """Compact Ipopt progress: one line per ``every`` iterations and the last one."""
    history = solved.history
    objective = history.get("objective", [])
    lines = []
    for k in range(len(objective)):
        if k % every == 0 or k == len(objective) - 1:
            lines.append(f"  iter {k:4d}  objective {objective[k]:11.4e}  "
                         f"constraint violation {history['constraint_violation'][k]:9.2e}  "
                         f"dual infeasibility {history['dual_infeasibility'][k]:9.2e}")
    return lines


def save_diagnostics(folder, measured_t, measured_q, fit, simulations) -> list[str]:
    """Write before_after.png and convergence.png into ``folder``; their names."""
    written = []
    fig, axes = new_figure(1, 2, figsize=(11, 3.8), wspace=0.25, title=True)
    for ax, joint in zip(axes, JOINTS, strict=True):
        plot_angles(joint, measured_t, measured_q, fit=fit, simulations=simulations, ax=ax)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"{fit.kind.replace('_', ' ')}: measured vs synthesized before/after")
    save_figure(fig, folder / "before_after.png")
    written.append("before_after.png")
    axes = plot_history(fit.solved)
    save_figure(axes[0].figure, folder / "convergence.png")
    written.append("convergence.png")
    return written
