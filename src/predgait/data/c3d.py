"""Read C3D files (via ezc3d): markers and force plates into the lab frame.

Force plates of TYPE 1 (forces, COP and free moment), TYPE 2 (forces and moments about the
sensor origin, six channels), TYPE 3 (Kistler, eight channels) and TYPE 4 (TYPE 2 through a
6x6 CAL_MATRIX) are supported. ezc3d returns analog values already multiplied by
ANALOG:SCALE and GEN_SCALE with OFFSET removed. The vertical is the plates' normal (Y-up
labs are common), else Z; a lab Z that does not look vertical is refused.

Plate frame (C3D convention, the same as ezc3d): x along corner1 - corner2, y along
corner1 - corner4, z = x cross y (into the plate, i.e. down). The analog channels hold the
wrench ON THE FOOT expressed in the plate frame at the sensor origin, which sits at
``ORIGIN`` (plate frame) from the centre of the plate surface. For a wrench (F, M) about
the origin O and the surface plane z = s (relative to O), the COP (x, y, s) is where the
horizontal moment vanishes::

    x = (s Fx - My) / Fz,   y = (Mx + s Fy) / Fz,   Tz = Mz - (x Fy - y Fx)

(Soutas-Little 1987, as in the thesis 3.2.2). Tz is the free moment about the COP.
"""

from __future__ import annotations

import dataclasses
import logging
import struct

import numpy as np

from predgait.data._io import (
    LENGTH_UNITS,
    check_magnitude,
    duplicate_labels,
    length_factor,
    open_input,
    zeros_as_missing,
)
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

_MOMENT_UNITS = {"nmm": 1e-3, "n.mm": 1e-3, "n mm": 1e-3, "n*mm": 1e-3, "nm": 1.0,
                 "n.m": 1.0, "n m": 1.0, "n*m": 1.0}

#: |Fz| (N) below which the COP is undefined and held at the plate centre.
COP_MIN_FORCE = 10.0


def _param(params, group: str, name: str, default=None):
    try:
        return params[group][name]["value"]
    except KeyError:
        return default


def plate_axes(corners: np.ndarray) -> np.ndarray:
    """Rotation (3, 3) from a plate's frame to the file frame, columns = plate x, y, z.

    Args:
        corners: (4, 3) corner positions in the file frame (C3D order).
    """
    x = corners[0] - corners[1]
    y = corners[0] - corners[3]
    z = np.cross(x, y)
    y = np.cross(z, x)
    return np.column_stack([v / np.linalg.norm(v) for v in (x, y, z)])


def plate_wrench_to_cop(force: np.ndarray, moment: np.ndarray, origin: np.ndarray, *,
                        min_force: float = COP_MIN_FORCE) -> tuple[np.ndarray, np.ndarray]:
    """COP and free moment in the plate frame from the wrench at the sensor origin.

    Args:
        force: (k, 3) N, plate frame.
        moment: (k, 3) N m about the sensor origin, plate frame.
        origin: (3,) m, sensor origin relative to the surface centre, plate frame.
        min_force: N; where |Fz| is smaller the COP is put at the surface centre and the
            free moment is the plain vertical moment.

    Returns:
        cop: (k, 3) m relative to the surface centre, plate frame (z = 0).
        free_moment: (k, 3) N m, (0, 0, Tz).
    """
    s = -origin[2]
    fx, fy, fz = force.T
    mx, my, mz = moment.T
    loaded = np.abs(fz) >= min_force
    safe = np.where(loaded, fz, 1.0)
    x = np.where(loaded, (s * fx - my) / safe, -origin[0])
    y = np.where(loaded, (mx + s * fy) / safe, -origin[1])
    tz = mz - (x * fy - y * fx)
    cop = np.column_stack([x + origin[0], y + origin[1], np.zeros_like(x)])
    free = np.column_stack([np.zeros_like(tz), np.zeros_like(tz), tz])
    return cop, free


def kistler_wrench(channels: np.ndarray, a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    """Force and moment (plate frame, about the sensor plane's centre) of a TYPE 3 plate.

    Args:
        channels: (k, 8) N: fx12, fx34, fy14, fy23, fz1, fz2, fz3, fz4 (Kistler order).
        a: sensor offset from the plate's centre along x (ORIGIN[0]).
        b: sensor offset from the plate's centre along y (ORIGIN[1]).

    Returns:
        force (k, 3) N and moment (k, 3) in the channels' force unit times the unit of a, b
        (Kistler, "Force plate formulae"; the C3D manual, TYPE 3).
    """
    fx12, fx34, fy14, fy23, fz1, fz2, fz3, fz4 = channels.T
    force = np.column_stack([fx12 + fx34, fy14 + fy23, fz1 + fz2 + fz3 + fz4])
    moment = np.column_stack([b * (fz1 + fz2 - fz3 - fz4), a * (fz2 + fz3 - fz1 - fz4),
                              b * (fx34 - fx12) + a * (fy14 - fy23)])
    return force, moment


#: Analog channels of each supported FORCE_PLATFORM:TYPE.
PLATE_CHANNELS = {1: 6, 2: 6, 3: 8, 4: 6}


def _unit_factor(units: list, channel: int, table: dict, default: str, *, source: str,
                 what: str) -> float:
    """Factor to SI of an analog channel's ANALOG:UNITS (``default`` when not stated)."""
    unit = units[channel] if len(units) > channel and str(units[channel]).strip() else default
    factor = table.get(str(unit).strip().lower())
    if factor is None:
        raise InputError(f"{source}: ANALOG:UNITS {unit!r} of the {what} (analog channel "
                         f"{channel + 1}) is not one of {', '.join(sorted(table))}.")
    return factor


def _plate_wrench(kind: int, raw: np.ndarray, origin: np.ndarray, cal: np.ndarray, p: int,
                  index: np.ndarray, units: list, length: float, source: str
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One plate's COP, free moment and force in the plate frame from its raw channels.

    Returns COP (k, 3) m from the surface centre, free moment (k, 3) N m, force (k, 3) N;
    ``raw`` (k, n) holds the analog channels, ``origin`` is ORIGIN (point unit) and
    ``length`` the point unit in m.
    """
    what = f"plate {p + 1} moments"
    if kind == 1:  # Fx, Fy, Fz, COPx, COPy (from the surface centre), Tz
        cop_factor = _unit_factor(units, index[3], LENGTH_UNITS, "mm" if length == 1e-3 else "m",
                                  source=source, what=f"plate {p + 1} COP")
        tz_factor = _unit_factor(units, index[5], _MOMENT_UNITS, "Nmm", source=source, what=what)
        zeros = np.zeros(len(raw))
        cop = np.column_stack([raw[:, 3] * cop_factor, raw[:, 4] * cop_factor, zeros])
        return cop, np.column_stack([zeros, zeros, raw[:, 5] * tz_factor]), raw[:, :3]
    if kind == 3:  # moments in N x (point unit); the sensor plane lies |az0| below the surface
        force, moment = kistler_wrench(raw, origin[0], origin[1])
        sensor = np.array([0.0, 0.0, abs(origin[2]) * length])
        return (*plate_wrench_to_cop(force, moment * length, sensor), force)
    if kind == 4:
        if cal.size < 36 * (p + 1):
            raise InputError(f"{source}: plate {p + 1} is TYPE 4 but FORCE_PLATFORM:CAL_MATRIX "
                             "is missing; re-export the plate with its calibration matrix.")
        raw = raw @ cal.reshape(6, 6, -1)[:, :, p].T
    m_factor = _unit_factor(units, index[3], _MOMENT_UNITS, "Nmm", source=source, what=what)
    # Vendors write ORIGIN (surface centre vs sensor origin) with either sign; the sensor
    # lies below the surface, i.e. at +z in the plate frame (z down), as ezc3d also assumes.
    origin = (-origin if origin[2] < 0 else origin) * length
    return (*plate_wrench_to_cop(raw[:, :3], raw[:, 3:] * m_factor, origin), raw[:, :3])


def _plates(params, analogs: np.ndarray, rate: float, point_factor: float,
            source: str) -> list[ForcePlate]:
    """Force plates in the FILE frame (forces on the foot, COP on the plate surface)."""
    used = int(np.ravel(_param(params, "FORCE_PLATFORM", "USED", [0]))[0])
    if used == 0:
        return []
    if not rate > 0:
        raise InputError(f"{source}: ANALOG:RATE is {rate!r} Hz but {used} force plate(s) are "
                         "used; re-export the trial with its analog channels.")
    types = np.ravel(_param(params, "FORCE_PLATFORM", "TYPE"))
    corners = np.asarray(_param(params, "FORCE_PLATFORM", "CORNERS"), dtype=float)
    corners = corners.reshape(3, 4, -1)
    origins = np.asarray(_param(params, "FORCE_PLATFORM", "ORIGIN"), dtype=float).reshape(3, -1)
    channels = np.asarray(_param(params, "FORCE_PLATFORM", "CHANNEL"), dtype=int)
    channels = channels.reshape(-1, used) if channels.ndim == 1 else channels
    cal = np.asarray(_param(params, "FORCE_PLATFORM", "CAL_MATRIX", []), dtype=float)
    units = list(_param(params, "ANALOG", "UNITS", []))
    time = np.arange(analogs.shape[1]) / rate
    plates = []
    for p in range(used):
        kind = int(types[p])
        if kind not in PLATE_CHANNELS:
            raise InputError(
                f"{source}: FORCE_PLATFORM:TYPE of plate {p + 1} is {kind}; predgait reads "
                "types 1 to 4. Export the plate as type 2 (forces and moments).")
        n_channels = PLATE_CHANNELS[kind]
        if channels.shape[0] < n_channels:
            raise InputError(f"{source}: FORCE_PLATFORM:CHANNEL lists {channels.shape[0]} "
                             f"channels per plate; a TYPE {kind} plate needs {n_channels}.")
        index = channels[:n_channels, p] - 1
        if index.min() < 0 or index.max() >= analogs.shape[0]:
            raise InputError(f"{source}: plate {p + 1} FORCE_PLATFORM:CHANNEL {index + 1} is "
                             f"outside the {analogs.shape[0]} analog channels.")
        c_file = corners[:, :, p].T * point_factor  # (4, 3) m
        if np.linalg.norm(np.cross(c_file[0] - c_file[1], c_file[0] - c_file[3])) < 1e-4:
            raise InputError(f"{source}: FORCE_PLATFORM:CORNERS of plate {p + 1} do not span a "
                             "surface; re-export the trial with the plates' corners.")
        cop_p, free_p, force_p = _plate_wrench(kind, analogs[index].T, origins[:, p], cal, p,
                                               index, units, point_factor, source)
        rotation = plate_axes(c_file)
        centre = c_file.mean(axis=0)
        check_magnitude(force_p, time, "force", source=f"{source} (plate {p + 1})")
        plates.append(ForcePlate(
            time=time, force=force_p @ rotation.T, cop=centre + cop_p @ rotation.T,
            free_moment=free_p @ rotation.T, name=str(p + 1), corners=c_file,
        ))
    return plates


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
    labels = [str(n).strip() for n in _param(params, "POINT", "LABELS", [])]
    more = 2
    while f"LABELS{more}" in params["POINT"]:
        labels += [str(n).strip() for n in _param(params, "POINT", f"LABELS{more}", [])]
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
    header_rate = c3d["header"]["points"]["frame_rate"]
    rate = float(np.ravel(_param(params, "POINT", "RATE", [header_rate]))[0])
    if not rate > 0:
        raise InputError(f"{path}: POINT:RATE is {rate!r} Hz; re-export the trial with its "
                         "frame rate.")
    stated = list(_param(params, "POINT", "UNITS", []))
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
        a_rate = float(np.ravel(_param(params, "ANALOG", "RATE", [0.0]))[0])
        analogs = c3d["data"]["analogs"][0]
        plate_list = _plates(params, analogs, a_rate, factor, str(path))
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
