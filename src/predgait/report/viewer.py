"""A 3D stick-figure viewer for the HTML report: data file and self-contained markup.

Commands write ``viewer.json`` (lab-frame positions of the model's stick lines over the
trial, simulated and measured, and ground reaction vectors); the report embeds it with
``viewer.js``, a ~150-line canvas renderer (drag to turn, wheel to zoom, a time slider).
A hand-written renderer rather than three.js: the report stays a single offline file of
a few kB more per viewer instead of 600 kB of library, and lines and arrows are all it
draws.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np

from predgait.report.stick import sample_times, stick_points

#: Colours: simulated, measured (reference), ground reaction.
SIMULATED, MEASURED, GRF = "#1f5fa8", "#a0a7ad", "#c62828"
#: Length of a ground-reaction arrow per newton, m/N (body weight ~ 0.7 m).
GRF_SCALE = 0.001
#: Planar models: drawn in their sagittal plane (lab Y = 0), as are their arrows.
PLANAR = ("leg", "rod", "gait7")


def _round(array) -> list:
    return np.round(np.asarray(array, dtype=float), 4).tolist()


def viewer_data(model, t, q, *, reference_q=None, grf=None, measured_grf=None,
                label: str = "simulated", max_frames: int = 150) -> dict:
    """Frames for the viewer.

    Args:
        model: Leg, rod, gait7 or full body (a kind of :data:`predgait.report.stick.LINES`).
        t: (n,) s.
        q: (n, nq) configurations of the main motion.
        reference_q: Optional (n, nq) measured motion at the same times (drawn grey).
        grf: Optional (force (n, 3) N, point (n, 3) m) drawn from the point (the main
            motion's ground reaction at its centre of pressure), or a mapping name -> such
            a pair (e.g. per foot or plate).
        measured_grf: Optional (force, point) of the measured ground reaction.
        A planar model's figure lies in the lab's X-Z plane, so its arrows are drawn there:
        the centre of pressure's lateral (Y) position and the lateral force are dropped
        (a plate's COP lies ~0.1 m beside the planar figure otherwise).
        label: Name of the main motion ("simulated", "measured", ...).
        max_frames: At most this many frames (the motion is subsampled).
    """
    t = np.asarray(t, dtype=float)
    rows = sample_times(t, max((t[-1] - t[0]) / max_frames, 1e-9)) if t.size > 1 else [0]
    bodies = [{"name": label, "color": SIMULATED,
               "lines": [_round(p) for p in stick_points(model, np.asarray(q)[rows],
                                                          plane=False)]}]
    if reference_q is not None:
        bodies.insert(0, {"name": "measured", "color": MEASURED, "lines": [
            _round(p) for p in stick_points(model, np.asarray(reference_q)[rows],
                                            plane=False)]})
    arrows = []
    simulated = grf if isinstance(grf, dict) else {"": grf}
    sets = [(f"ground reaction{', ' + name if name else ''}", GRF, pair)
            for name, pair in simulated.items()]
    for name, colour, pair in [*sets, ("measured ground reaction", MEASURED, measured_grf)]:
        if pair is None:
            continue
        force, point = (np.array(np.asarray(a, dtype=float)[rows]) for a in pair)
        if model.kind in PLANAR:
            force[:, 1], point[:, 1] = 0.0, 0.0
        loaded = np.abs(force[:, 2]) > 20.0
        point = np.where(loaded[:, None], point, np.nan)
        arrows.append({"name": name, "color": colour, "origin": _round(point),
                       "vector": _round(GRF_SCALE * force)})
    return {"time": _round(t[rows]), "bodies": bodies, "arrows": arrows,
            "model": model.kind}


def contact_grf(model, q, forces, frames, groups) -> list[tuple[np.ndarray, np.ndarray]]:
    """Ground reaction per group of contact points: total force at the loaded points' centre.

    Args:
        model: The model (Pinocchio frames ``frames``).
        q: (n, nq) configurations.
        forces: (n, len(frames), 3) N, lab-frame force at each contact point.
        frames: Contact frame names.
        groups: Per arrow, the frame names summed (e.g. the heel and toe of one foot).

    Returns:
        Per group, (force (n, 3) N, point (n, 3) m; the vertical-force-weighted mean of
        its points, NaN when unloaded).
    """
    import pinocchio as pin

    pm, data = model.pin_model, model.pin_model.createData()
    ids = [model.frame_id(name) for name in frames]
    pos = np.zeros((len(q), len(frames), 3))
    for k, qk in enumerate(np.asarray(q)):
        pin.framesForwardKinematics(pm, data, qk)
        pos[k] = [data.oMf[i].translation for i in ids]
    out = []
    for group in groups:
        cols = [frames.index(name) for name in group]
        force = forces[:, cols].sum(axis=1)
        weight = np.clip(forces[:, cols, 2], 0.0, None)
        total = weight.sum(axis=1, keepdims=True)
        with np.errstate(invalid="ignore", divide="ignore"):
            point = (weight[:, :, None] * pos[:, cols]).sum(axis=1) / total
        out.append((force, point))
    return out


def plate_arrows(plates, time, t, *, prefix: str = "plate") -> dict:
    """Per force plate, (force (m, 3) N, COP (m, 3) m) at the times ``t`` (nearest frame).

    Args:
        plates: Force plates resampled at ``time`` (e.g. ``Inverse3DResult.plates``).
        time: (n,) s, the plates' rows.
        t: (m,) s wanted (within ``time``).
        prefix: Arrow name before the plate's name.
    """
    time, t = np.asarray(time, dtype=float), np.asarray(t, dtype=float)
    rows = np.clip(np.searchsorted(time, t - 1e-9), 0, time.size - 1)
    return {f"{prefix} {plate.name}": (np.asarray(plate.force)[rows],
                                       np.asarray(plate.cop)[rows]) for plate in plates}


def write_viewer(path: str | Path, data: dict) -> Path:
    """Write viewer data as JSON (NaN as null)."""
    text = json.dumps(data, separators=(",", ":")).replace("NaN", "null")
    Path(path).write_text(text + "\n")
    return Path(path)


def viewer_script() -> str:
    """The renderer's JavaScript (included once per page)."""
    from importlib import resources

    return resources.files("predgait.report").joinpath("viewer.js").read_text()


def viewer_markup(data_text: str, title: str) -> str:
    """A viewer block: canvas, controls and the frames as inline JSON."""
    safe = data_text.strip().replace("</", "<\\/")
    try:
        arrows = [a.get("name", "") for a in json.loads(data_text).get("arrows", ())]
    except (ValueError, AttributeError):
        arrows = []
    shown = html.escape(f"arrows: {', '.join(arrows)} at the centre of pressure, 1 m per "
                        "1000 N" if arrows else "no ground reaction arrows in this result")
    return ("<figure class='pg-viewer'><canvas width='720' height='440' "
            "style='border:1px solid #ddd;max-width:100%;cursor:grab'></canvas>"
            "<div><button type='button'>pause</button> <input type='range' min='0' "
            "value='0' style='width:60%'> <span class='pg-time'></span></div>"
            f"<figcaption>{title} — 3D view: drag to turn, wheel to zoom; "
            f"{shown}</figcaption>"
            f"<script type='application/json'>{safe}</script></figure>")


def write_motion(folder: str | Path, model, t, q, *, reference_q=None, grf=None,
                 measured_grf=None, label: str = "simulated") -> None:
    """``stick.gif`` (sagittal stick figure) and ``viewer.json`` (3D) of a motion.

    Arguments as in :func:`viewer_data`; the GIF draws ``reference_q`` in grey behind.
    """
    from predgait.report.stick import write_gif

    folder = Path(folder)
    write_gif(folder / "stick.gif", model, t, q, reference_q=reference_q, label=label)
    write_viewer(folder / "viewer.json", viewer_data(
        model, t, q, reference_q=reference_q, grf=grf, measured_grf=measured_grf,
        label=label))
