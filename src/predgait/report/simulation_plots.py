"""Charts of forward simulations: angles vs measured, GRF/COP, contributions, deviation.

Each function returns the :class:`~predgait.report.raster.Panel` list of one figure, written
with :func:`predgait.report.raster.save_chart` (Pillow line charts, no Matplotlib: a
re-synthesis run spent about half its wall time importing Matplotlib and drawing).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from predgait.kinematics.clinical import clinical_joint
from predgait.report.raster import Line, Panel

#: Colours of successive runs or parts (Matplotlib's default cycle); measured motion is black.
COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
          "#7f7f7f", "#bcbd22", "#17becf")
MEASURED = "#000000"
#: x-axis labels of runs: the leg's trials start at heel strike (time 0); a run from rest.
FROM_HEEL_STRIKE = "time from heel strike (s)"
FROM_START = "time from the start of the run (s)"


def _signs(names, kind: str | None) -> list[tuple[str, float]]:
    """Per coordinate, its shown name and sign: the clinical one for a joint of ``kind``."""
    shown = []
    for name in names:
        if kind is None or name.startswith("base_"):
            shown.append((name, 1.0))
        else:
            joint = clinical_joint(kind, name)
            shown.append((joint.angle.replace("_", " "), joint.sign))
    return shown


def coordinate_panels(runs: Mapping[str, tuple[np.ndarray, np.ndarray]], names, *,
                      reference=None, degrees: bool = True, kind: str | None = None,
                      xlabel: str = FROM_HEEL_STRIKE) -> list[Panel]:
    """Coordinates over time, one panel per name (a column of panels).

    Args:
        runs: Label -> (t (n,), q (n, k)) with columns in ``names`` order.
        names: Coordinate names (panel titles).
        reference: Optional (t, q (m, k)) measured motion, drawn black.
        degrees: Show angles in degrees (names starting base_x/base_z stay in m).
        kind: Model kind ("leg"): joints are shown as their clinical angles (knee
            flexion positive), by :func:`predgait.kinematics.clinical.clinical_joint`.
        xlabel: What the time axis is (which time zero).
    """
    panels = []
    for j, (name, sign) in enumerate(_signs(names, kind)):
        scale = sign * (np.degrees(1.0) if degrees and name not in ("base_x", "base_z")
                        else 1.0)
        lines = [Line(np.asarray(t), np.asarray(q)[:, j] * scale, color=COLORS[k % len(COLORS)],
                      label=label if j == 0 else None)
                 for k, (label, (t, q)) in enumerate(runs.items())]
        if reference is not None:  # drawn first, behind the runs
            lines.insert(0, Line(np.asarray(reference[0]), np.asarray(reference[1])[:, j] * scale,
                              color=MEASURED, width=1.0, label="measured" if j == 0 else None))
        panels.append(Panel(tuple(lines), ylabel=f"{name} ({'deg' if abs(scale) != 1 else 'm'})",
                            xlabel=xlabel if j == len(names) - 1 else ""))
    return panels


def grf_panels(t, grf, cop, *, measured=None, xlabel: str = FROM_HEEL_STRIKE) -> list[Panel]:
    """Synthesized (and measured) vertical/horizontal ground reaction and COP X.

    Args:
        t: (n,) s.
        grf: (n, 3) N.
        cop: (n, 3) m; drawn where the vertical force exceeds 20 N.
        measured: Optional (t, grf, cop) of the trial, drawn black.
        xlabel: What the time axis is.
    """
    sets = [("synthesized", t, grf, cop, COLORS[0])]
    if measured is not None:
        sets.append(("measured", *measured, MEASURED))
    fz, fx, cx = [], [], []
    for label, tt, f, c, color in sets:
        tt, f, c = np.asarray(tt), np.asarray(f), np.asarray(c)
        fz.append(Line(tt, f[:, 2], color=color, label=label))
        fx.append(Line(tt, f[:, 0], color=color))
        cx.append(Line(tt, np.where(np.abs(f[:, 2]) > 20, c[:, 0], np.nan), color=color))
    return [Panel(tuple(fz), ylabel="F_z (N)"), Panel(tuple(fx), ylabel="F_x (N)"),
            Panel(tuple(cx), ylabel="COP x (m)", xlabel=xlabel)]


def contribution_panels(t, parts: Mapping[str, np.ndarray], names, *, kind: str | None = None,
                        xlabel: str = FROM_HEEL_STRIKE) -> list[Panel]:
    """Acceleration contributions per free joint (thesis Fig. 4.2.12); "total" in black.

    ``kind`` ("leg") shows each joint's acceleration in its clinical sign.
    """
    panels = []
    for j, (name, sign) in enumerate(_signs(names, kind)):
        lines = []
        for k, (part, values) in enumerate(parts.items()):
            total = part == "total"
            lines.append(Line(np.asarray(t), sign * np.asarray(values)[:, j],
                              color=MEASURED if total else COLORS[k % len(COLORS)],
                              width=2.0 if total else 1.0, label=part if j == 0 else None))
        panels.append(Panel(tuple(lines), ylabel=f"{name} acc. (rad/s^2)",
                            xlabel=xlabel if j == len(names) - 1 else ""))
    return panels


def deviation_panel(t, q, reference, names, *, threshold_deg: float, time_to_threshold=None,
                    time_to_fall=None, kind: str | None = "leg",
                    xlabel: str = FROM_HEEL_STRIKE) -> Panel:
    """Simulated minus measured angle per joint (deg) with the ±threshold band.

    The y range is at most ±5 thresholds (a diverging run is cut at the frame); where the
    deviation leaves the band and the fall are dotted vertical lines, named in the title.

    Args:
        t: (n,) s of the simulation.
        q: (n, k) simulated angles, rad, columns in ``names`` order.
        reference: (t_ref (m,), q_ref (m, k)) measured angles, rad.
        names: Joint names.
        threshold_deg: Half-width of the band, deg.
        time_to_threshold: s, when the deviation first leaves the band.
        time_to_fall: s, the fall.
        kind: Model kind: the deviations are differences of clinical angles (None: model
            coordinates).
        xlabel: What the time axis is.
    """
    t, q = np.asarray(t), np.asarray(q)
    ref_t, ref_q = (np.asarray(a) for a in reference)
    signs = _signs(names, kind)
    names = [name for name, _ in signs]
    errors = [sign * np.degrees(q[:, j] - np.interp(t, ref_t, ref_q[:, j]))
              for j, (_, sign) in enumerate(signs)]
    limit = max(5 * threshold_deg, 1.0)
    finite = np.concatenate([e[np.isfinite(e)] for e in errors] + [np.zeros(1)])
    low = max(min(finite.min(), -threshold_deg) * 1.05, -limit)
    high = min(max(finite.max(), threshold_deg) * 1.05, limit)
    lines = tuple(Line(t, np.clip(e, low, high), color=COLORS[j % len(COLORS)], label=name)
                  for j, (name, e) in enumerate(zip(names, errors, strict=True)))
    notes = []
    if time_to_threshold is not None:
        notes.append(f"leaves ±{threshold_deg:g} deg at {time_to_threshold:.3f} s")
    if time_to_fall is not None:
        notes.append(f"fall at {time_to_fall:.3f} s")
    return Panel(lines, title="; ".join(notes), xlabel=xlabel,
                 ylabel="simulated - measured, clinical angle (deg)", hlines=(0.0,),
                 vlines=tuple(v for v in (time_to_threshold, time_to_fall) if v is not None),
                 ylim=(low, high), band=(-threshold_deg, threshold_deg))
