"""Read C3D files (via ezc3d): markers and force plates into the lab frame.

Plates: :mod:`predgait.data.c3d_plates` (TYPE 1-4). The vertical is the plates' normal
(Y-up labs are common), else Z; a lab Z that does not look vertical is refused.
"""

from __future__ import annotations

import dataclasses
import logging
import struct

import numpy as np

from predgait.data._io import (
    check_magnitude,
    check_marker_labels,
    duplicate_labels,
    length_factor,
    open_input,
    zeros_as_missing,
)
from predgait.data.c3d_plates import param, plate_axes, read_plates
from predgait.data.frames import (
    FileAxes,
    Forward,
    axis_up_rotation,
    check_vertical,
    lab_rotation,
    parse_enum,
    rotate_trial,
    up_from_plates,
    up_rotation,
)
from predgait.data.trial import ForcePlate, Markers, Trial
from predgait.errors import InputError

logger = logging.getLogger(__name__)


def _header_frames(path) -> int | None:
    """Frames the C3D header announces (None if not stated there).

    Checks first that the file holds its whole header and parameter section: ezc3d can
    crash on a file cut inside them.
    """
    size = path.stat().st_size
    with path.open("rb") as handle:
        head = handle.read(512)
        if len(head) < 512 or head[1] != 0x50 or head[0] < 2:
            raise InputError(f"{path}: not a C3D file (no C3D header in its first 512 bytes).")
        handle.seek((head[0] - 1) * 512 + 3)
        processor = handle.read(1)
    order = ">" if processor == bytes([86]) else "<"  # 86: MIPS (big-endian); 84/85: Intel/DEC
    first, last = struct.unpack(f"{order}2H", head[6:10])
    data_block = struct.unpack(f"{order}H", head[16:18])[0]
    if data_block < 2 or size < (data_block - 1) * 512:
        raise InputError(f"{path}: the file ends inside its header or parameters ({size} "
                         f"bytes; data should start at byte {(data_block - 1) * 512}); it looks "
                         "truncated. Re-export it.")
    return None if last >= 65535 else last - first + 1


#: N; a plate whose vertical force only reaches below -MIN_LOAD (never above +MIN_LOAD)
#: records the force ON THE PLATE and is negated.
MIN_LOAD = 50.0


def _file_up(plates: list[ForcePlate], axes: FileAxes, source: str) -> np.ndarray:
    """Rotation (3, 3) from the file frame to a Z-up frame (the forward axis comes later)."""
    if axes is not FileAxes.AUTO:
        return up_rotation(axes)
    if not plates:
        return np.eye(3)
    normals = np.array([-plate_axes(p.corners)[:, 2] for p in plates])
    return axis_up_rotation(up_from_plates(normals, source=f"{source} FORCE_PLATFORM:CORNERS"))


def _point_labels(params) -> list[str]:
    """Marker labels: POINT:LABELS, then LABELS2, LABELS3, ... (more than 255 markers)."""
    labels = [str(n).strip() for n in param(params, "POINT", "LABELS", [])]
    more = 2
    while f"LABELS{more}" in params["POINT"]:
        labels += [str(n).strip() for n in param(params, "POINT", f"LABELS{more}", [])]
        more += 1
    return labels


def _on_the_foot(plate: ForcePlate, source: str) -> ForcePlate:
    """The plate with its wrench negated if the file stores the force on the plate."""
    fz = plate.force[:, 2]
    if np.nanmax(fz) < MIN_LOAD < -np.nanmin(fz):
        logger.warning("%s: plate %s pushes down (vertical force down to %.0f N); reading it "
                       "as the force on the plate and negating it", source, plate.name,
                       np.nanmin(fz))
        return dataclasses.replace(plate, force=-plate.force, free_moment=-plate.free_moment)
    return plate


def read_c3d(path, *, forward: Forward | str = Forward.AUTO, axes: FileAxes | str = FileAxes.AUTO,
             plates: bool = True) -> Trial:
    """Read a C3D file: markers (m) and force plates at the analog rate, lab frame.

    Args:
        path: the .c3d file.
        forward: file axis of progression, or "auto" (detected from the marker centroid;
            treadmill-like trials with < 0.3 m travel keep +X).
        axes: the file's vertical convention: "auto" takes the force plates' normal (Y-up
            labs) and Z-up without plates; a lab Z that does not look vertical is refused.
        plates: read the force plates too.

    Returns:
        Trial with time zero at the first frame in the file.
    """
    import ezc3d

    axes = parse_enum(axes, FileAxes, field="axes", source=str(path))
    path = open_input(path)
    header_frames = _header_frames(path)
    try:
        c3d = ezc3d.c3d(str(path))
    except Exception as exc:  # ezc3d raises RuntimeError/IOError for bad files
        raise InputError(f"{path}: ezc3d could not read it as C3D ({exc}).") from None
    params = c3d["parameters"]
    labels = _point_labels(params)
    n_read, n_markers = c3d["data"]["points"].shape[2], c3d["data"]["points"].shape[1]
    if n_markers == 0:
        raise InputError(f"{path}: no marker data (POINT:USED = 0); predgait needs marker "
                         "trajectories: export the trial with its markers.")
    if len(labels) < n_markers:
        raise InputError(f"{path}: {n_markers} markers but POINT:LABELS names {len(labels)}; "
                         "re-export the trial with every marker labelled.")
    expected = header_frames
    if expected is not None and n_read < expected:
        raise InputError(f"{path}: {n_read} frames read but the header says {expected}; the "
                         "file looks truncated. Re-export it.")
    if n_read < 2:
        raise InputError(f"{path}: {n_read} frame(s); a trial needs at least two.")
    duplicate_labels(labels[:n_markers], source=str(path), what="marker label")
    check_marker_labels(labels[:n_markers], source=str(path), where="POINT:LABELS")
    header_rate = c3d["header"]["points"]["frame_rate"]
    rate = float(np.ravel(param(params, "POINT", "RATE", [header_rate]))[0])
    if not rate > 0:
        raise InputError(f"{path}: POINT:RATE is {rate!r} Hz; re-export the trial with its "
                         "frame rate.")
    stated = list(param(params, "POINT", "UNITS", []))
    unit = (stated or ["mm"])[0]
    factor = length_factor(unit, source=str(path), field="POINT:UNITS")
    points = c3d["data"]["points"][:3]  # (3, m, n)
    xyz = np.transpose(points, (2, 1, 0)) * factor
    residuals = c3d["data"]["meta_points"]["residuals"][0].T  # (n, m)
    xyz[residuals < 0] = np.nan
    zeros_as_missing(xyz, source=str(path))
    check_magnitude(xyz, np.arange(xyz.shape[0]) / rate, "marker", source=str(path),
                    names=labels)
    markers = Markers(time=np.arange(xyz.shape[0]) / rate, names=tuple(labels[:n_markers]),
                      xyz=xyz, rate=rate, source=str(path))
    plate_list = []
    if plates and "FORCE_PLATFORM" in params:
        a_rate = float(np.ravel(param(params, "ANALOG", "RATE", [0.0]))[0])
        analogs = c3d["data"]["analogs"][0]
        plate_list = read_plates(params, analogs, a_rate, factor, str(path))
    up = _file_up(plate_list, axes, str(path))
    z_up = np.einsum("ij,nmj->nmi", up, xyz)
    check_vertical(z_up, source=str(path), convention=(
        "Z-up (a C3D file without force plates)" if axes is FileAxes.AUTO and not plate_list
        else "vertical along the force plates' normal" if axes is FileAxes.AUTO
        else f"axes {axes.value!r}"),
        unit_field=f"POINT:UNITS {unit!r}" + ("" if stated else " (not stated: mm assumed)"))
    trial = Trial(markers=markers, plates=tuple(plate_list), source=str(path))
    rotation = lab_rotation(FileAxes.Z_UP, forward, xyz=z_up, source=str(path)) @ up
    trial = rotate_trial(trial, rotation)
    return dataclasses.replace(trial, plates=tuple(_on_the_foot(p, str(path))
                                                   for p in trial.plates))
