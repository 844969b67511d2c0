"""What every report plot states: its x axis and the sign convention of what it shows.

Each PNG predgait writes (Pillow charts of :mod:`predgait.report.raster`, Matplotlib figures
of :mod:`predgait.report.figures`) carries two PNG text chunks, filled from the labels drawn
on it: :data:`X_AXIS` (the x-axis labels, e.g. "% gait cycle", "time from heel strike (s)")
and :data:`LABELS` (the axes' titles and y labels). The HTML report writes the x axis
under each figure and states :data:`SIGN_CONVENTION` once, at the top of the page; the
report tests read the chunks back (:func:`read_labels`) to check that every plot names its
x axis and shows joint quantities under their clinical names (the signs of
:mod:`predgait.kinematics.clinical`). An animated GIF carries its caption (what is drawn, in
which colour) as its GIF comment (:func:`gif_caption`).
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from pathlib import Path

#: PNG text key of the x-axis labels ("; "-separated).
X_AXIS = "predgait x-axis"
#: PNG text key of what the axes show: their titles and y labels (" | "-separated; legend
#: entries and figure titles, which name runs and problems, are not in it).
LABELS = "predgait labels"

#: The one sign convention of every report (README "Usage"; kinematics.clinical).
SIGN_CONVENTION = ("Signs: clinical throughout. Hip flexion, knee flexion, ankle "
                   "dorsiflexion (3D: also adduction, internal rotation, inversion) are "
                   "positive; a joint moment is internal and positive when it acts toward "
                   "the positive angle; ground reactions act on the foot in the lab frame "
                   "(X forward, Z up). Each plot names its x axis: % gait cycle or % stride "
                   "(from the heel strike of the side shown), time from heel strike (s), "
                   "trial time (s) or time from the start of a run (s).")


def _unique(texts: Iterable[str]) -> list[str]:
    return list(dict.fromkeys(t.strip() for t in texts if t and t.strip()))


def png_text(x_labels: Iterable[str], labels: Iterable[str]) -> dict[str, str]:
    """The two text chunks of a plot from the labels drawn on it."""
    return {X_AXIS: "; ".join(_unique(x_labels)), LABELS: " | ".join(_unique(labels))}


def figure_text(fig) -> dict[str, str]:
    """:func:`png_text` of a Matplotlib figure (its axes' x labels, titles and y labels)."""
    x_labels, labels = [], []
    for ax in fig.axes:
        if ax.get_visible():
            x_labels.append(ax.get_xlabel())
            labels += [ax.get_ylabel(), ax.get_title()]
    return png_text(x_labels, labels)


def read_labels(path: str | Path) -> tuple[list[str], list[str]]:
    """(x-axis labels, other labels) stored in a PNG written by predgait (empty if none)."""
    from PIL import Image

    with Image.open(path) as image:
        text = getattr(image, "text", {}) or {}
    return _split(text.get(X_AXIS, ""), "; "), _split(text.get(LABELS, ""), " | ")


def _split(text: str, sep: str) -> list[str]:
    return [part for part in text.split(sep) if part]


def gif_caption(path: str | Path) -> str:
    """The caption stored in a GIF's comment by :mod:`predgait.report.stick` ('' if none)."""
    from PIL import Image

    with Image.open(path) as image:
        comment = image.info.get("comment", b"")
    return comment.decode("utf-8", "replace") if isinstance(comment, bytes) else str(comment)


_X_QUALIFIED = re.compile(r"% gait cycle|% stride|time from heel strike|trial time|"
                          r"time from the start|time after start")
_JOINT = re.compile(r"\b(hip|knee|ankle|elbow|lumbar|shoulder)\b", re.IGNORECASE)
_CLINICAL = re.compile(r"flexion|extension|adduction|abduction|rotation|inversion|eversion",
                       re.IGNORECASE)


def label_problems(x_labels: Iterable[str], labels: Iterable[str]) -> list[str]:
    """What a plot fails to state (empty: nothing).

    The plot must name its x axis; a time or percentage axis must say from when (% gait
    cycle or % stride, time from heel strike, trial time, time from the start); a title or
    y label naming a joint must name its clinical angle ("knee flexion", not "knee"), the
    sign of :mod:`predgait.kinematics.clinical`.
    """
    x_labels, problems = list(x_labels), []
    if not x_labels:
        problems.append("no x-axis label")
    for label in x_labels:
        if ("time" in label.lower() or "%" in label) and not _X_QUALIFIED.search(label):
            problems.append(f"x axis {label!r} does not say from when")
    problems += [f"{label!r} names a joint without its clinical angle" for label in labels
                 if _JOINT.search(label) and not _CLINICAL.search(label)]
    return problems
