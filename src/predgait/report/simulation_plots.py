"""Plots of forward simulations: angles vs measured, GRF/COP, contributions, rod runs.

Each function takes ``ax=None`` (a new figure) and returns the axes.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np


def _axes(ax, n=1, figsize=(6, 4)):
    from predgait.report.figures import new_figure

    if ax is not None:
        return ax
    _, axes = new_figure(n, 1, figsize=figsize, sharex=True, squeeze=False, hspace=0.15)
    return axes[:, 0] if n > 1 else axes[0, 0]


def plot_coordinates(runs: Mapping[str, tuple[np.ndarray, np.ndarray]], names, *,
                     reference=None, ax=None, degrees: bool = True):
    """Coordinates over time, one panel per name.

    Args:
        runs: Label -> (t (n,), q (n, k)) with columns in ``names`` order.
        names: Coordinate names (panel titles).
        reference: Optional (t, q (m, k)) measured motion, drawn black dashed.
        ax: Sequence of len(names) axes, or None.
        degrees: Show angles in degrees (names starting base_x/base_z stay in m).
    """
    axes = _axes(ax, len(names), figsize=(6, 2.2 * len(names)))
    axes = np.atleast_1d(axes)
    for j, (name, a) in enumerate(zip(names, axes, strict=True)):
        scale = np.degrees(1.0) if degrees and name not in ("base_x", "base_z") else 1.0
        for label, (t, q) in runs.items():
            a.plot(t, np.asarray(q)[:, j] * scale, label=label)
        if reference is not None:
            a.plot(reference[0], np.asarray(reference[1])[:, j] * scale, "k--", label="measured")
        a.set_ylabel(f"{name} ({'deg' if scale != 1 else 'm'})")
    axes[-1].set_xlabel("time (s)")
    axes[0].legend(fontsize=7)
    return axes


def plot_grf(t, grf, cop, *, measured=None, ax=None):
    """Synthesized (and measured) vertical/horizontal ground reaction and COP X.

    Args:
        t: (n,) s.
        grf: (n, 3) N.
        cop: (n, 3) m.
        measured: Optional (t, grf, cop) of the trial.
        ax: Three axes or None.
    """
    axes = np.atleast_1d(_axes(ax, 3, figsize=(6, 7)))
    sets = [("synthesized", t, grf, cop, "-")]
    if measured is not None:
        sets.append(("measured", *measured, "k--"))
    for label, tt, f, c, style in sets:
        axes[0].plot(tt, f[:, 2], style, label=label)
        axes[1].plot(tt, f[:, 0], style, label=label)
        loaded = np.abs(f[:, 2]) > 20
        axes[2].plot(np.asarray(tt)[loaded], np.asarray(c)[loaded, 0], style, label=label)
    axes[0].set_ylabel("F_z (N)")
    axes[1].set_ylabel("F_x (N)")
    axes[2].set_ylabel("COP x (m)")
    axes[2].set_xlabel("time (s)")
    axes[0].legend(fontsize=7)
    return axes


def plot_contributions(t, parts: Mapping[str, np.ndarray], names, *, ax=None):
    """Acceleration contributions per free joint (thesis Fig. 4.2.12)."""
    axes = np.atleast_1d(_axes(ax, len(names), figsize=(6, 2.6 * len(names))))
    for j, (name, a) in enumerate(zip(names, axes, strict=True)):
        for part, values in parts.items():
            style = "k-" if part == "total" else "-"
            a.plot(t, values[:, j], style, lw=2 if part == "total" else 1, label=part)
        a.set_ylabel(f"{name} acc. (rad/s^2)")
    axes[0].legend(fontsize=7, ncol=3)
    axes[-1].set_xlabel("time (s)")
    return axes


def plot_deviation(t, q, reference, names, *, threshold_deg: float, time_to_threshold=None,
                   time_to_fall=None, ax=None):
    """Simulated minus measured angle per joint (deg), the threshold band shaded.

    Args:
        t: (n,) s of the simulation.
        q: (n, k) simulated angles, rad, columns in ``names`` order.
        reference: (t_ref (m,), q_ref (m, k)) measured angles, rad.
        names: Joint names.
        threshold_deg: Half-width of the band, deg.
        time_to_threshold: s, when the deviation first leaves the band (dotted line).
        time_to_fall: s, the fall (red dashed line).
        ax: One axes or None.
    """
    if ax is None:
        from predgait.report.figures import new_figure

        _, ax = new_figure(figsize=(7, 3.8), title=True)
    t, q = np.asarray(t), np.asarray(q)
    ref_t, ref_q = (np.asarray(a) for a in reference)
    for j, name in enumerate(names):
        error = np.degrees(q[:, j] - np.interp(t, ref_t, ref_q[:, j]))
        ax.plot(t, error, lw=1.5, label=name)
    if time_to_fall is not None:
        ax.axvline(time_to_fall, color="#b00020", ls="--", lw=1.2, label="fall")
    ax.axhspan(-threshold_deg, threshold_deg, color="#2a6f97", alpha=0.12,
               label=f"±{threshold_deg:g} deg")
    if time_to_threshold is not None:
        ax.axvline(time_to_threshold, color="0.3", ls=":", lw=1)
        ax.text(time_to_threshold, threshold_deg, f" leaves ±{threshold_deg:g} deg at "
                f"{time_to_threshold:.3f} s", fontsize=8, va="bottom")
    limit = max(5 * threshold_deg, 1.0)
    low, high = ax.get_ylim()
    ax.set_ylim(max(low, -limit), min(high, limit))
    ax.set_xlabel("time (s)")
    ax.set_ylabel("simulated - measured (deg)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower left")
    fall = "" if time_to_fall is None else f"; fall at {time_to_fall:.3f} s"
    ax.figure.suptitle(f"Deviation from the measured motion{fall}", fontsize=10)
    return ax
