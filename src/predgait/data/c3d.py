"""Read C3D files (via ezc3d): markers and force plates into the lab frame.

Force plates of TYPE 2 (forces and moments about the sensor origin, six channels) and
TYPE 4 (the same through a 6x6 CAL_MATRIX) are supported. ezc3d returns analog values
already multiplied by ANALOG:SCALE and GEN_SCALE with OFFSET removed.

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

import logging
import struct

import numpy as np

from predgait.data._io import check_magnitude, duplicate_labels, length_factor, open_input
from predgait.data.frames import FileAxes, Forward, lab_rotation, rotate_trial
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


def _plates(params, analogs: np.ndarray, rate: float, point_factor: float,
            source: str) -> list[ForcePlate]:
    used = int(np.ravel(_param(params, "FORCE_PLATFORM", "USED", [0]))[0])
    if used == 0:
        return []
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
        if kind not in (2, 4):
            raise InputError(
                f"{source}: FORCE_PLATFORM:TYPE of plate {p + 1} is {kind}; predgait reads "
                "types 2 and 4 only. Export the plate as type 2 (forces and moments)."
            )
        index = channels[:6, p] - 1
        if index.max() >= analogs.shape[0]:
            raise InputError(f"{source}: plate {p + 1} CHANNEL {index + 1} exceeds the analogs.")
        raw = analogs[index].T  # (k, 6)
        if kind == 4:
            if cal.size < 36 * (p + 1):
                raise InputError(f"{source}: plate {p + 1} is TYPE 4 but has no CAL_MATRIX.")
            raw = raw @ cal.reshape(6, 6, -1)[:, :, p].T
        m_unit = units[index[3]] if len(units) > index[3] else "Nmm"
        m_factor = _MOMENT_UNITS.get(m_unit.strip().lower())
        if m_factor is None:
            raise InputError(f"{source}: ANALOG:UNITS {m_unit!r} of plate {p + 1} moments "
                             "is not N mm or N m.")
        c_file = corners[:, :, p].T * point_factor  # (4, 3) m
        origin = origins[:, p] * point_factor
        rotation = plate_axes(c_file)
        cop_p, free_p = plate_wrench_to_cop(raw[:, :3], raw[:, 3:] * m_factor, origin)
        centre = c_file.mean(axis=0)
        check_magnitude(raw[:, :3], time, "force", source=f"{source} (plate {p + 1})")
        plates.append(ForcePlate(
            time=time, force=raw[:, :3] @ rotation.T, cop=centre + cop_p @ rotation.T,
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


def read_c3d(path, *, forward: Forward | str = Forward.AUTO, axes: FileAxes | str = FileAxes.Z_UP,
             plates: bool = True) -> Trial:
    """Read a C3D file: markers (m) and force plates at the analog rate, lab frame.

    Args:
        path: the .c3d file.
        forward: file axis of progression, or "auto" (detected from the marker centroid;
            treadmill-like trials with < 0.3 m travel keep +X).
        axes: the file's vertical convention (C3D is usually Z-up).
        plates: read the force plates too.

    Returns:
        Trial with time zero at the first frame in the file.
    """
    import ezc3d

    path = open_input(path)
    expected = _header_frames(path)
    try:
        c3d = ezc3d.c3d(str(path))
    except Exception as exc:  # ezc3d raises RuntimeError/IOError for bad files
        raise InputError(f"{path}: ezc3d could not read it as C3D ({exc}).") from None
    params = c3d["parameters"]
    labels = [str(n).strip() for n in _param(params, "POINT", "LABELS", [])]
    n_read = c3d["data"]["points"].shape[2]
    if expected is not None and n_read < expected:
        raise InputError(f"{path}: {n_read} frames read but the header says {expected}; the "
                         "file looks truncated. Re-export it.")
    if n_read < 2:
        raise InputError(f"{path}: {n_read} frame(s); a trial needs at least two.")
    duplicate_labels(labels[: c3d["data"]["points"].shape[1]], source=str(path),
                     what="marker label")
    header_rate = c3d["header"]["points"]["frame_rate"]
    rate = float(np.ravel(_param(params, "POINT", "RATE", [header_rate]))[0])
    unit = _param(params, "POINT", "UNITS", ["mm"])[0]
    factor = length_factor(unit, source=str(path), field="POINT:UNITS")
    points = c3d["data"]["points"][:3]  # (3, m, n)
    xyz = np.transpose(points, (2, 1, 0)) * factor
    residuals = c3d["data"]["meta_points"]["residuals"][0].T  # (n, m)
    xyz[residuals < 0] = np.nan
    check_magnitude(xyz, np.arange(xyz.shape[0]) / rate, "marker", source=str(path),
                    names=labels)
    markers = Markers(time=np.arange(xyz.shape[0]) / rate, names=tuple(labels[: xyz.shape[1]]),
                      xyz=xyz, rate=rate, source=str(path))
    plate_list = []
    if plates and "FORCE_PLATFORM" in params:
        a_rate = float(np.ravel(_param(params, "ANALOG", "RATE", [0.0]))[0])
        analogs = c3d["data"]["analogs"][0]
        plate_list = _plates(params, analogs, a_rate, factor, str(path))
    trial = Trial(markers=markers, plates=tuple(plate_list), source=str(path))
    rotation = lab_rotation(axes, forward, xyz=xyz, source=str(path))
    return rotate_trial(trial, rotation)
