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
