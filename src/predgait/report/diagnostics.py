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

#: Free joint -> (column in the full coordinates, column in the free state).
JOINTS = {joint: (3 + i, i) for i, joint in enumerate(LEG_FREE_JOINTS)}


def _axes(ax):
    if ax is None:
        _, ax = new_figure(figsize=(5, 3.4))
    return ax


def plot_history(solved, ax=None):
    """Objective and constraint violation (log scale) per Ipopt iteration.

    Args:
        solved: A :class:`predgait.problems.collocation.Solved` (its ``history``).
        ax: Axes to draw on; None makes a figure.

    Returns:
        The axes (objective on the left scale; a twin axis holds the violation).
    """
    ax = _axes(ax)
    history = solved.history
    objective = np.asarray(history.get("objective", ()), dtype=float)
    violation = np.asarray(history.get("constraint_violation", ()), dtype=float)
    ax.semilogy(np.maximum(np.abs(objective), 1e-300), "C0.-", label="objective")
    ax.set_xlabel("Ipopt iteration")
    ax.set_ylabel("|objective|", color="C0")
    twin = ax.twinx()
    twin.semilogy(np.maximum(violation, 1e-300), "C3.-", label="constraint violation")
    twin.set_ylabel("constraint violation (inf_pr)", color="C3")
    ax.set_title(f"{solved.status}, {solved.iterations} iterations, "
                 f"{solved.seconds * 1e3:.0f} ms")
    ax.grid(alpha=0.3)
    return ax


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
    ax = plot_history(fit.solved)
    save_figure(ax.figure, folder / "convergence.png")
    written.append("convergence.png")
    return written
