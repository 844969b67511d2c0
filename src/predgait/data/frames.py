"""Axis mapping from a file's own frame into the lab frame, applied once at the boundary.

Lab frame: X forward (direction of progression), Y lateral (left), Z up; right-handed.

* OpenSim files are Y-up: X forward, Y up, Z to the right. The lab coordinates are
  ``(x, -z, y)`` of the OpenSim ones, i.e. ``R = [[1,0,0],[0,0,-1],[0,1,0]]`` (a +90 deg
  rotation about X, det = +1).
* C3D files are usually Z-up with an arbitrary walking direction. A rotation about Z
  brings the chosen (or detected) direction of travel onto +X.

Every rotation here is proper (det = +1) so handedness, cross products and free moments
keep their meaning; the same matrix is applied to markers, COP, forces and moments.
"""

from __future__ import annotations

import dataclasses
import logging
import warnings
from enum import StrEnum

import numpy as np

from predgait.data.medians import finite_median
from predgait.data.trial import ForcePlate, Markers, Trial
from predgait.errors import InputError

logger = logging.getLogger(__name__)


class FileAxes(StrEnum):
    """Vertical convention of a file: OpenSim's Y-up, Z-up, or "auto" (C3D: plate normal)."""

    OPENSIM = "opensim"
    Z_UP = "z_up"
    AUTO = "auto"


class Forward(StrEnum):
    """Which file axis (after the Z-up mapping) points in the direction of progression."""

    PLUS_X = "+x"
    MINUS_X = "-x"
    PLUS_Y = "+y"
    MINUS_Y = "-y"
    AUTO = "auto"


#: OpenSim (X forward, Y up, Z right) -> lab (X forward, Y left, Z up).
OPENSIM_TO_LAB = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])

_ABOUT_Z = {
    Forward.PLUS_X: np.eye(3),
    Forward.MINUS_X: np.diag([-1.0, -1.0, 1.0]),
    Forward.PLUS_Y: np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
    Forward.MINUS_Y: np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
}

#: Net horizontal travel (m) below which a trial counts as treadmill-like (keep +X).
MIN_TRAVEL = 0.3


def parse_enum(value, enum_type, *, field: str, source: str = ""):
    """Convert a string (or enum member) to ``enum_type`` with a clear InputError."""
    try:
        return enum_type(value)
    except ValueError:
        allowed = ", ".join(repr(m.value) for m in enum_type)
        raise InputError(
            f"{source + ': ' if source else ''}{field}={value!r} is not valid; "
            f"use one of {allowed}."
        ) from None


def up_rotation(axes: FileAxes | str) -> np.ndarray:
    """Rotation (3, 3) from a file's axes to a Z-up frame with the file's forward axis."""
    axes = parse_enum(axes, FileAxes, field="axes")
    if axes is FileAxes.AUTO:
        raise InputError("axes='auto' needs the file's force plates; give 'z_up' or 'opensim'.")
    return OPENSIM_TO_LAB.copy() if axes is FileAxes.OPENSIM else np.eye(3)


def axis_up_rotation(up: np.ndarray) -> np.ndarray:
    """Proper rotation (3, 3) taking the file's signed axis ``up`` (a unit axis) onto +Z.

    The first file axis perpendicular to ``up`` becomes +X (the forward direction is
    chosen afterwards by a rotation about Z).
    """
    up = np.asarray(up, dtype=float)
    forward = np.eye(3)[int(np.flatnonzero(np.abs(up) < 0.5)[0])]
    return np.vstack([forward, np.cross(up, forward), up])


#: Largest angle (deg) between a plate's normal and the nearest file axis.
MAX_PLATE_TILT = 10.0


def up_from_plates(normals: np.ndarray, *, source: str) -> np.ndarray:
    """The file's signed axis pointing up, from the force plates' upward normals.

    Args:
        normals: (p, 3) upward unit normals of the plates' surfaces, file frame.
        source: file name for the message.

    Returns:
        (3,) the signed unit file axis nearest to the mean normal.
    """
    mean = np.mean(normals, axis=0)
    axis = int(np.argmax(np.abs(mean)))
    up = np.sign(mean[axis]) * np.eye(3)[axis]
    tilt = np.degrees(np.arccos(np.clip(normals @ up, -1.0, 1.0)))
    if np.max(tilt) > MAX_PLATE_TILT:
        raise InputError(
            f"{source}: a force plate's normal (FORCE_PLATFORM:CORNERS) is {np.max(tilt):.0f} "
            "deg from every file axis; predgait needs level plates on a lab axis. Check the "
            "plates' corners or re-export the trial with a vertical lab axis.")
    return up


#: The vertical extent of the marker cloud must be at least this fraction of the widest
#: horizontal extent (median over frames); a standing or walking body is taller than wide.
MIN_VERTICAL_SHARE = 0.5

#: Range (m) of the widest extent (median over frames) of a body's markers.
BODY_EXTENT = (0.05, 5.0)


def check_vertical(xyz: np.ndarray, *, source: str, convention: str, unit_field: str = ""
                   ) -> None:
    """Refuse markers whose lab Z does not look vertical, or whose size is not a body's.

    Args:
        xyz: (n, m, 3) markers already mapped to the lab frame, m.
        source: file name for the message.
        convention: what was assumed, e.g. "Z-up (C3D without force plates)".
        unit_field: the file's length-unit field, named when the size is implausible
            (e.g. ``POINT:UNITS 'mm'``); no size check when empty.
    """
    if xyz.shape[1] < 3:
        return
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        extent = finite_median(np.nanmax(xyz, axis=1) - np.nanmin(xyz, axis=1))
    if not np.all(np.isfinite(extent)):
        return
    low, high = BODY_EXTENT
    if unit_field and not low <= extent.max() <= high:
        raise InputError(
            f"{source}: the markers span {extent.max():.3g} m (median over frames) but a body "
            f"spans {low:g} to {high:g} m; check the length unit {unit_field}.")
    widest = int(np.argmax(extent[:2]))
    if extent[2] < MIN_VERTICAL_SHARE * extent[widest]:
        raise InputError(
            f"{source}: read as {convention}, the markers span {extent[2]:.2f} m vertically "
            f"but {extent[widest]:.2f} m along the lab {'XY'[widest]} axis; the file's vertical "
            "axis looks different. Re-export it with the vertical axis predgait assumes.")


def centroid_travel(xyz: np.ndarray) -> np.ndarray:
    """Net displacement (3,) of the marker centroid, robust to markers entering and leaving.

    The centroid velocity is taken frame by frame from the markers visible in both frames,
    so a marker dropping out does not make the centroid jump.

    Args:
        xyz: (n, m, 3) marker positions, NaN where missing.

    Returns:
        (3,) net displacement of the centroid over the trial (same units as ``xyz``).
    """
    steps = np.diff(np.asarray(xyz, dtype=float), axis=0)  # (n-1, m, 3)
    valid = np.all(np.isfinite(steps), axis=2)
    count = valid.sum(axis=1)
    total = np.where(valid[:, :, None], steps, 0.0).sum(axis=1)
    mean_step = np.divide(total, count[:, None], out=np.zeros_like(total), where=count[:, None] > 0)
    return mean_step.sum(axis=0)


def detect_forward(xyz: np.ndarray, *, min_travel: float = MIN_TRAVEL) -> Forward:
    """Horizontal direction of travel of a Z-up trial.

    Args:
        xyz: (n, m, 3) m, Z-up frame.
        min_travel: m; below this net centroid travel the trial is treadmill-like and
            the file's +X is kept.

    Returns:
        The :class:`Forward` axis closest to the centroid's net horizontal travel.
    """
    travel = centroid_travel(xyz)
    horizontal = travel[:2]
    if np.hypot(*horizontal) < min_travel:
        logger.info("net travel %.3f m < %.2f m: treadmill-like, keeping +X forward",
                    np.hypot(*horizontal), min_travel)
        return Forward.PLUS_X
    axis = int(np.argmax(np.abs(horizontal)))
    positive = int(horizontal[axis] > 0)
    return [[Forward.MINUS_X, Forward.PLUS_X], [Forward.MINUS_Y, Forward.PLUS_Y]][axis][positive]


def lab_rotation(axes: FileAxes | str, forward: Forward | str = Forward.PLUS_X, *,
                 xyz: np.ndarray | None = None, source: str = "") -> np.ndarray:
    """Rotation R (3, 3) with ``v_lab = R @ v_file`` for a file's axes and forward direction.

    Args:
        axes: the file's vertical convention.
        forward: file axis (after mapping to Z-up) pointing forward, or "auto".
        xyz: (n, m, 3) marker positions in the file frame, needed for "auto".
        source: file name for error messages.

    Returns:
        (3, 3) proper rotation matrix.
    """
    forward = parse_enum(forward, Forward, field="forward", source=source)
    up = up_rotation(axes)
    if forward is Forward.AUTO:
        if xyz is None:
            raise InputError(f"{source}: forward='auto' needs marker data to detect travel.")
        forward = detect_forward(np.einsum("ij,nmj->nmi", up, xyz))
        logger.info("%s: detected forward direction %s", source, forward.value)
    return _ABOUT_Z[forward] @ up


def rotate_vectors(rotation: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Apply ``rotation`` (3, 3) to vectors (..., 3)."""
    return np.einsum("ij,...j->...i", rotation, np.asarray(vectors, dtype=float))


def rotate_markers(markers: Markers, rotation: np.ndarray) -> Markers:
    """Markers with every position rotated by ``rotation``."""
    return dataclasses.replace(markers, xyz=rotate_vectors(rotation, markers.xyz))


def rotate_plate(plate: ForcePlate, rotation: np.ndarray) -> ForcePlate:
    """Force plate with force, COP, free moment and corners rotated by ``rotation``."""
    corners = None if plate.corners is None else rotate_vectors(rotation, plate.corners)
    return dataclasses.replace(
        plate,
        force=rotate_vectors(rotation, plate.force),
        cop=rotate_vectors(rotation, plate.cop),
        free_moment=rotate_vectors(rotation, plate.free_moment),
        corners=corners,
    )


def rotate_trial(trial: Trial, rotation: np.ndarray) -> Trial:
    """Trial with markers and plates rotated by ``rotation``."""
    return dataclasses.replace(
        trial,
        markers=rotate_markers(trial.markers, rotation),
        plates=tuple(rotate_plate(p, rotation) for p in trial.plates),
    )
