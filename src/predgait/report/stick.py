"""Stick figures of the leg, rod, gait7 or full body (thesis Figs. 4.2.2, 4.2.5, 4.2.8), GIF."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

#: Polylines drawn per model kind, by frame name.
LINES = {"leg": (("heel", "toe", "ankle_center", "heel"), ("ankle_center", "knee_center"),
                 ("knee_center", "hip_center")),
         "rod": (("bottom", "top"),),
         "gait7": tuple(line for s in ("r", "l") for line in (
             ("hip_center", f"knee_center_{s}", f"ankle_center_{s}"),
             (f"heel_{s}", f"toe_{s}", f"ankle_center_{s}", f"heel_{s}"))),
         "fullbody": (("hip_center_r", "lumbar_center", "hip_center_l", "hip_center_r"),
                      ("lumbar_center", "c7", "head_top"),
                      ("shoulder_center_r", "shoulder_center_l"),
                      *(line for s in ("r", "l") for line in (
                          (f"hip_center_{s}", f"knee_center_{s}", f"ankle_center_{s}"),
                          (f"heel_contact_{s}", f"toe_contact_{s}", f"ankle_center_{s}",
                           f"heel_contact_{s}"),
                          (f"shoulder_center_{s}", f"elbow_center_{s}", f"hand_{s}"))))}


def stick_points(model, q: np.ndarray, *, plane: bool = True) -> list[np.ndarray]:
    """Per polyline, the lab positions of its points for each row of q (n, nq).

    Args:
        model: A model whose ``kind`` is a key of :data:`LINES`.
        q: (n, nq) configurations.
        plane: X, Z only (sagittal plane, (n, k, 2)); else X, Y, Z ((n, k, 3)).
    """
    import pinocchio as pin  # here: a dataset report (html.py) draws no stick figure

    pm = model.pin_model
    data = pm.createData()
    q = np.atleast_2d(q)
    lines = LINES[model.kind]
    names = sorted({n for line in lines for n in line})
    ids = {n: model.frame_id(n) for n in names}
    axes = [0, 2] if plane else [0, 1, 2]
    pos = {n: np.zeros((len(q), len(axes))) for n in names}
    for k, qk in enumerate(q):
        pin.framesForwardKinematics(pm, data, qk)
        for n in names:
            pos[n][k] = data.oMf[ids[n]].translation[axes]
    return [np.stack([pos[n] for n in line], axis=1) for line in lines]


def sample_times(t: np.ndarray, interval: float) -> np.ndarray:
    """Row indices of t nearest to t0, t0 + interval, ... (no repeats)."""
    targets = np.arange(t[0], t[-1] + 1e-9, interval)
    rows = np.clip(np.searchsorted(t, targets - 1e-9), 0, len(t) - 1)  # non-decreasing
    keep = np.ones(rows.size, dtype=bool)   # np.unique's result without its numpy.ma import
    keep[1:] = rows[1:] != rows[:-1]
    return rows[keep]


def plot_stick(model, t, q, *, interval: float = 0.05, ax=None, color=None, label=None,
               offset: float = 0.0):
    """Overlay the figure at ``interval`` s (darker = later); returns the axes.

    Args:
        model: Leg or rod.
        t: (n,) s.
        q: (n, nq) coordinates.
        interval: Time between drawn figures, s (thesis: 0.05 s).
        ax: Matplotlib axes (new figure when None).
        color: Line colour (default: grey scale in time).
        label: Legend label of the last figure.
        offset: Horizontal shift of the drawing, m (to put runs side by side).
    """
    if ax is None:
        from predgait.report.figures import new_figure

        _, ax = new_figure(figsize=(4, 5))
    rows = sample_times(np.asarray(t), interval)
    lines = stick_points(model, np.asarray(q)[rows])
    for j in range(len(rows)):
        shade = color or str(0.75 * (1 - j / max(1, len(rows) - 1)))
        for pts in lines:
            ax.plot(pts[j, :, 0] + offset, pts[j, :, 1], "-o", color=shade, ms=2, lw=1.2,
                    label=label if (j == len(rows) - 1 and pts is lines[0]) else None)
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_aspect("equal")
    ax.set_xlabel("X (m)")
    ax.set_ylabel("Z (m)")
    return ax


def save_stick_chart(path: str | Path, model, t, runs: Mapping[str, np.ndarray], *,
                     interval: float = 0.05, height: float = 4.5) -> Path:
    """Stick-figure overlays side by side as one PNG (Pillow), darker = later.

    Args:
        path: Output .png.
        model: A model whose ``kind`` is a key of :data:`LINES` (planar figures).
        t: (n,) s, common to the runs.
        runs: Panel title -> (n, nq) coordinates (rows beyond a run's end are ignored).
        interval: Time between drawn figures, s (thesis Fig. 4.2.2: 0.05 s).
        height: Figure height, inches (the width follows from the motion's extent).

    Returns:
        ``path``.
    """
    from predgait.report.raster import DPI, MARGINS, TEXT, Axes, Canvas

    t = np.asarray(t)
    drawn = {}
    for title, q in runs.items():
        q = np.asarray(q)
        drawn[title] = stick_points(model, q[sample_times(t[:len(q)], interval)])
    allpts = np.concatenate([p.reshape(-1, 2) for lines in drawn.values() for p in lines])
    allpts = allpts[np.all(np.isfinite(allpts), axis=1)]
    lo, hi = allpts.min(axis=0) - 0.05, allpts.max(axis=0) + 0.05
    lo[1] = min(lo[1], -0.05)
    left, right, bottom, top = MARGINS
    aspect = float(np.clip((hi[0] - lo[0]) / (hi[1] - lo[1]), 0.3, 3.0))
    panel_width = (height - bottom - top) * aspect
    gap = 0.6
    canvas = Canvas((left + right + len(drawn) * panel_width + gap * (len(drawn) - 1), height))
    s = DPI * canvas.scale
    for k, (title, lines) in enumerate(drawn.items()):
        x0 = (left + k * (panel_width + gap)) * s
        axes = Axes(canvas, (x0, top * s, x0 + panel_width * s, canvas.height - bottom * s),
                    (lo[0], hi[0]), (lo[1], hi[1]), equal=True)
        axes.frame(title=title, xlabel="X (m)", ylabel="Z (m)" if k == 0 else "")
        axes.polyline(axes.xlim, (0.0, 0.0), color=TEXT, width=0.5)
        count = len(lines[0])
        for j in range(count):
            grey = round(255 * 0.75 * (1 - j / max(1, count - 1)))
            for pts in lines:
                axes.polyline(pts[j, :, 0], pts[j, :, 1], color=f"#{grey:02x}{grey:02x}{grey:02x}",
                              width=1.2, dots=3.0)
    return canvas.save_png(path)


def write_gif(path: str | Path, model, t, q, *, reference_q=None, fps: int = 20,
              max_frames: int = 80, label: str = "simulated") -> Path:
    """Animated stick figure (Pillow GIF); the reference motion in grey if given.

    The GIF's comment is its caption, naming what is drawn in which colour (the report
    shows it; :func:`predgait.report.plot_labels.gif_caption`).

    Args:
        path: Output .gif.
        model: Leg, rod or gait7 (planar figures; see :data:`LINES`).
        t: (n,) s.
        q: (n, nq) coordinates.
        reference_q: Optional (n, nq) measured motion drawn behind.
        fps: Frames per second of the animation.
        max_frames: At most this many frames (the trial is subsampled).
        label: What ``q`` is ("simulated", "measured (IK)", ...), for the caption.
    """
    t, q = np.asarray(t), np.asarray(q)
    rows = sample_times(t, max(1.0 / fps, (t[-1] - t[0]) / max_frames))
    sim = stick_points(model, q[rows])
    ref = stick_points(model, np.asarray(reference_q)[rows]) if reference_q is not None else []
    caption = (f"Stick figure, sagittal plane (animation): {label} in blue"
               + (", measured in grey behind" if ref else ""))
    return write_polyline_gif(path, t[rows], sim, ref, fps=fps, caption=caption)


def write_polyline_gif(path: str | Path, times, lines, reference_lines=(), *,
                       fps: int = 20, size: tuple[float, float] | None = None,
                       caption: str = "") -> Path:
    """GIF of polylines in the X-Z plane, one frame per time.

    Args:
        path: Output .gif.
        times: (k,) s, shown in the title.
        lines: Per polyline, (k, points, 2) X, Z in m (drawn blue).
        reference_lines: Same layout, drawn grey behind (the measured motion).
        fps: Frames per second.
        size: Figure size, inches (None: from the extent of the motion).
        caption: Stored as the GIF comment (what is drawn, in which colour).
    """
    from predgait.report.raster import MARGINS, TEXT, Axes, Canvas

    allpts = np.concatenate([p.reshape(-1, 2) for p in [*lines, *reference_lines]])
    allpts = allpts[np.all(np.isfinite(allpts), axis=1)]
    lo, hi = allpts.min(axis=0) - 0.1, allpts.max(axis=0) + 0.1
    if size is None:  # about 4.5 inches high, as wide as the motion needs
        aspect = np.clip((hi[0] - lo[0]) / max(hi[1] - min(lo[1], -0.05), 1e-3), 0.5, 2.5)
        size = (1.2 + 3.6 * aspect, 4.5)
    # Palette frames drawn at the final size: no per-frame colour quantisation.
    palette = ("white", TEXT, "#e4e4e4", "#b3b3b3", "#1f77b4")
    background = Canvas(size, scale=1, palette=palette)
    left, right, bottom, top = (m * 110 for m in MARGINS)
    axes = Axes(background, (left, top, background.width - right, background.height - bottom),
                (lo[0], hi[0]), (min(lo[1], -0.05), hi[1]), equal=True)
    axes.frame(xlabel="X (m)", ylabel="Z (m)")
    axes.polyline(axes.xlim, (0.0, 0.0), color=TEXT, width=0.5)
    frames = []
    for j, time in enumerate(times):
        canvas = background.copy()
        view = axes.on(canvas)
        for pts in reference_lines:
            view.polyline(pts[j, :, 0], pts[j, :, 1], color="#b3b3b3", width=2.0)
        for pts in lines:
            view.polyline(pts[j, :, 0], pts[j, :, 1], color="#1f77b4", width=1.5, dots=3.0)
        canvas.text(((axes.box[0] + axes.box[2]) / 2, axes.box[1] - canvas.px(4.0)),
                    f"t = {time:.2f} s", size=12.0, anchor="md")
        frames.append(canvas.image)
    path = Path(path)
    frames[0].save(path, save_all=True, append_images=frames[1:], duration=int(1000 / fps),
                   loop=0, optimize=False, comment=caption.encode("utf-8"))
    return path
