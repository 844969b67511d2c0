"""C3D force plates (FORCE_PLATFORM group) into wrenches on the foot, file frame.

Force plates of TYPE 1 (forces, COP and free moment), TYPE 2 (forces and moments about the
sensor origin, six channels), TYPE 3 (Kistler, eight channels) and TYPE 4 (TYPE 2 through a
6x6 CAL_MATRIX) are supported. ezc3d returns analog values already multiplied by
ANALOG:SCALE and GEN_SCALE with OFFSET removed.

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

import numpy as np

from predgait.data._io import LENGTH_UNITS, check_magnitude
from predgait.data.trial import ForcePlate
from predgait.errors import InputError


def param(params, group: str, name: str, default=None):
    """Value of the C3D parameter GROUP:NAME from ezc3d's dictionary, else ``default``."""
    try:
        return params[group][name]["value"]
    except KeyError:
        return default


_MOMENT_UNITS = {"nmm": 1e-3, "n.mm": 1e-3, "n mm": 1e-3, "n*mm": 1e-3, "nm": 1.0,
                 "n.m": 1.0, "n m": 1.0, "n*m": 1.0}

#: |Fz| (N) below which the COP is undefined and held at the plate centre.
COP_MIN_FORCE = 10.0


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
        point_unit = {1e-3: "mm", 1e-2: "cm"}.get(length, "m")
        cop_factor = _unit_factor(units, index[3], LENGTH_UNITS, point_unit, source=source,
                                  what=f"plate {p + 1} COP")
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


#: N; samples loaded at least this much must have their COP on the plate.
COP_CHECK_FORCE = 100.0
#: m; how far beyond the plate's edge such a COP may lie (noise, the foot's edge).
COP_MARGIN = 0.1


def _check_cop_on_plate(cop: np.ndarray, force: np.ndarray, corners: np.ndarray,
                        time: np.ndarray, what: str) -> None:
    """Refuse a plate whose loaded COP lies off the plate (moment units, ORIGIN, channels).

    Args:
        cop: (k, 3) m from the surface centre, plate frame.
        force: (k, 3) N, plate frame.
        corners: (4, 3) m from the surface centre, plate frame.
        time: (k,) s.
        what: file and plate, for the message.
    """
    loaded = np.abs(force[:, 2]) >= COP_CHECK_FORCE
    if loaded.sum() < 10:
        return
    half = np.abs(corners[:, :2]).max(axis=0)
    beyond = np.max(np.abs(cop[:, :2]) - half, axis=1)
    off = loaded & (beyond > COP_MARGIN)
    if off.mean() > 0.1 * loaded.mean():
        first = int(np.flatnonzero(off)[0])
        raise InputError(
            f"{what}: the centre of pressure lies {beyond[first]:.2f} m beyond the plate's "
            f"edge at t = {time[first]:.3f} s (and at {off.sum()} of {loaded.sum()} loaded "
            "samples); check the moment channels' ANALOG:UNITS, FORCE_PLATFORM:ORIGIN and "
            "FORCE_PLATFORM:CHANNEL.")


def read_plates(params, analogs: np.ndarray, rate: float, point_factor: float,
            source: str) -> list[ForcePlate]:
    """Force plates of a C3D file in the FILE frame (forces on the foot, COP on the surface).

    Args:
        params: ezc3d's parameters.
        analogs: (channels, k) analog values (ezc3d applied SCALE, GEN_SCALE, OFFSET).
        rate: Hz, ANALOG:RATE.
        point_factor: the point unit in m (CORNERS, ORIGIN and TYPE 1/3 lengths use it).
        source: file name for messages.
    """
    used = int(np.ravel(param(params, "FORCE_PLATFORM", "USED", [0]))[0])
    if used == 0:
        return []
    if not rate > 0:
        raise InputError(f"{source}: ANALOG:RATE is {rate!r} Hz but {used} force plate(s) are "
                         "used; re-export the trial with its analog channels.")
    types = np.ravel(param(params, "FORCE_PLATFORM", "TYPE"))
    corners = np.asarray(param(params, "FORCE_PLATFORM", "CORNERS"), dtype=float)
    corners = corners.reshape(3, 4, -1)
    origins = np.asarray(param(params, "FORCE_PLATFORM", "ORIGIN"), dtype=float).reshape(3, -1)
    channels = np.asarray(param(params, "FORCE_PLATFORM", "CHANNEL"), dtype=int)
    channels = channels.reshape(-1, used) if channels.ndim == 1 else channels
    cal = np.asarray(param(params, "FORCE_PLATFORM", "CAL_MATRIX", []), dtype=float)
    units = list(param(params, "ANALOG", "UNITS", []))
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
        _check_cop_on_plate(cop_p, force_p, (c_file - centre) @ rotation, time,
                            f"{source}: plate {p + 1} (TYPE {kind})")
        plates.append(ForcePlate(
            time=time, force=force_p @ rotation.T, cop=centre + cop_p @ rotation.T,
            free_moment=free_p @ rotation.T, name=str(p + 1), corners=c_file,
        ))
    return plates
