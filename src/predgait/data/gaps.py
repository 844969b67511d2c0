"""Find and fill gaps (NaN runs) in marker trajectories."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from predgait.data.frames import parse_enum
from predgait.data.trial import Markers
from predgait.errors import InputError
from predgait.numerics.spline import CubicSpline

logger = logging.getLogger(__name__)


class Edges(StrEnum):
    """What to do with NaNs at the start or end of a trajectory (never interpolated)."""

    KEEP = "keep"    # leave them NaN (logged)
    TRIM = "trim"    # cut the trial to the frames where every selected marker is present
    ERROR = "error"  # raise InputError


@dataclass(frozen=True)
class Gap:
    """A run of missing frames of one marker: frames ``start .. stop - 1`` (0-based)."""

    marker: str
    start: int
    stop: int
    interior: bool

    @property
    def length(self) -> int:
        """Number of missing frames."""
        return self.stop - self.start


def find_gaps(markers: Markers, names: Sequence[str] | None = None) -> list[Gap]:
    """All NaN runs of the given markers (all markers if None)."""
    gaps = []
    for name in names or markers.names:
        missing = np.isnan(markers.get(name)).any(axis=1)
        edges = np.diff(np.concatenate([[0], missing.astype(int), [0]]))
        for start, stop in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1),
                               strict=True):
            gaps.append(Gap(name, int(start), int(stop),
                            interior=bool(start > 0 and stop < missing.size)))
    return gaps


def fill_gaps(markers: Markers, *, max_gap_frames: int | None = None,
              max_gap_seconds: float | None = None, names: Sequence[str] | None = None,
              edges: Edges | str = Edges.KEEP) -> Markers:
    """Fill interior gaps by a cubic spline through each marker's present frames.

    Args:
        markers: trajectories with NaN gaps.
        max_gap_frames: longest gap (frames) to fill.
        max_gap_seconds: longest gap (s) to fill; the stricter of the two limits applies.
            With neither, gaps up to 10 frames are filled.
        names: markers to process (others are dropped); all if None.
        edges: leading/trailing NaNs: keep, trim the trial, or raise.

    Returns:
        Markers with the gaps filled (and, with ``edges="trim"``, fewer frames).

    Raises:
        InputError: a gap longer than the limit (naming marker, frames and times), or
            edge NaNs with ``edges="error"``, or a marker with fewer than 4 present frames.
    """
    edges = parse_enum(edges, Edges, field="edges", source=markers.source)
    limits = [v for v in (max_gap_frames,
                          None if max_gap_seconds is None else int(np.floor(
                              max_gap_seconds * markers.rate + 1e-9)))
              if v is not None]
    limit = min(limits) if limits else 10
    if names is not None:
        markers = markers.select(names)
    gaps = find_gaps(markers)
    t = markers.time
    for gap in gaps:
        where = (f"marker {gap.marker!r} is missing in frames {gap.start + 1}..{gap.stop} "
                 f"(t = {t[gap.start]:.3f}..{t[gap.stop - 1]:.3f} s, {gap.length} frames)")
        if gap.interior and gap.length > limit:
            raise InputError(
                f"{markers.source}: {where}, longer than the {limit}-frame limit for gap "
                "filling. Raise max_gap_frames (problem file [options]), drop the marker, or "
                "analyse a window without the gap."
            )
        if not gap.interior and edges is Edges.ERROR:
            raise InputError(f"{markers.source}: {where} at the edge of the trial; "
                             "use edges='trim' or choose a window.")
        if not gap.interior:
            logger.info("%s: %s at the edge of the trial", markers.source, where)
    xyz = markers.xyz.copy()
    for j, name in enumerate(markers.names):
        present = ~np.isnan(xyz[:, j]).any(axis=1)
        if present.all():
            continue
        if present.sum() < 4:
            raise InputError(f"{markers.source}: marker {name!r} is present in only "
                             f"{int(present.sum())} frames; it cannot be gap-filled.")
        first, last = np.flatnonzero(present)[[0, -1]]
        inside = np.zeros_like(present)
        inside[first:last + 1] = True
        fill = inside & ~present
        if fill.any():
            spline = CubicSpline(t[present], xyz[present, j])
            xyz[fill, j] = spline.values(t[fill])
    filled = markers.with_xyz(xyz)
    if edges is Edges.TRIM:
        complete = ~np.isnan(xyz).any(axis=(1, 2))
        if not complete.any():
            raise InputError(f"{markers.source}: no frame has all of {markers.names} present.")
        first, last = np.flatnonzero(complete)[[0, -1]]
        filled = filled.window(t[first], t[last])
    return filled
