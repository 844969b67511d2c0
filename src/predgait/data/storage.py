"""Read and write OpenSim storage files (.sto/.mot) and CSV tables.

Storage layout: optional name line, ``key=value`` header lines until ``endheader``, a
line of column labels, then rows (tab- or space-separated). Ground reactions in a MOT
follow OpenSim's naming ``<prefix>ground_force_vx/vy/vz`` (N), ``..._px/py/pz`` (COP)
and ``<prefix>ground_torque_x/y/z`` (N m), one prefix per foot or plate.
"""

from __future__ import annotations

import re
import threading
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from predgait.data._io import (
    atomic_write_text,
    check_magnitude,
    duplicate_labels,
    length_factor,
    open_input,
    read_input,
)
from predgait.data.frames import FileAxes, lab_rotation, rotate_plate
from predgait.data.trial import ForcePlate, uniform_time
from predgait.errors import InputError


@dataclass(frozen=True, eq=False)
class Storage:
    """Columns of an OpenSim storage file.

    Attributes:
        time: (n,) s.
        columns: label -> (n,) values (units as in the file).
        header: ``key=value`` header entries (``inDegrees``, ``nRows``, ...).
        in_degrees: True when the header says ``inDegrees=yes``.
        source: file name.
    """

    time: np.ndarray
    columns: dict[str, np.ndarray]
    header: dict[str, str]
    in_degrees: bool
    source: str

    def column(self, name: str) -> np.ndarray:
        """One column; raises InputError listing the available labels."""
        if name not in self.columns:
            raise InputError(
                f"{self.source}: no column {name!r}. Columns: {', '.join(self.columns)}."
            )
        return self.columns[name]


def read_storage(path) -> Storage:
    """Read an OpenSim .sto/.mot file.

    Args:
        path: the file.

    Returns:
        :class:`Storage` with the time column (label ``time``, else the first) apart.

    Raises:
        InputError: missing file, no ``endheader``, ragged or non-numeric rows.
    """
    path, text = read_input(path, what="OpenSim .sto/.mot file")
    lines = text.splitlines()
    end = next((i for i, ln in enumerate(lines) if ln.strip().lower() == "endheader"), None)
    if end is None:
        raise InputError(f"{path}: no 'endheader' line; is this an OpenSim .sto/.mot file?")
    header = {}
    for line in lines[:end]:
        if "=" in line:
            key, _, value = line.strip().partition("=")
            header[key.strip()] = value.strip()
    body = [ln for ln in lines[end + 1:] if ln.strip()]
    if not body:
        raise InputError(f"{path}: no column labels after 'endheader'.")
    labels = body[0].split("\t") if "\t" in body[0] else body[0].split()
    labels = [lb.strip() for lb in labels if lb.strip()]
    duplicate_labels(labels, source=str(path))
    rows = [line.split() for line in body[1:]]
    try:   # all rows at once (NumPy parses each field as float() does)
        if any(len(fields) != len(labels) for fields in rows):
            raise ValueError
        rows = np.array(rows, dtype=float)
    except ValueError:   # the first bad line, for the message
        for number, fields in enumerate(rows, start=end + 3):
            if len(fields) != len(labels):
                raise InputError(
                    f"{path}: line {number} has {len(fields)} values for {len(labels)} "
                    "columns; the file may be truncated."
                ) from None
            try:
                [float(f) for f in fields]
            except ValueError:
                raise InputError(f"{path}: line {number} has a non-numeric value.") from None
        raise
    if "nRows" in header and header["nRows"].isdigit() and int(header["nRows"]) > len(rows):
        raise InputError(
            f"{path}: {len(rows)} rows but the header says nRows={header['nRows']}; "
            "the file looks truncated."
        )
    if len(rows) < 2:
        raise InputError(f"{path}: {len(rows)} data row(s) after the column labels; a trial "
                         "needs at least two rows.")
    data = rows.reshape(len(rows), len(labels))
    lower = [lb.lower() for lb in labels]
    t_index = lower.index("time") if "time" in lower else 0
    steps = np.diff(data[:, t_index])
    if not np.all(np.isfinite(data[:, t_index])) or not np.all(steps > 0):
        bad = int(np.flatnonzero(~(steps > 0))[0]) + 1 if steps.size else 0
        raise InputError(f"{path}: the time column does not increase at line "
                         f"{end + 3 + bad}; rows must be in time order, one per frame.")
    columns = {lb: data[:, i] for i, lb in enumerate(labels) if i != t_index}
    in_degrees = header.get("inDegrees", "no").lower().startswith("y")
    return Storage(data[:, t_index], columns, header, in_degrees, str(path))


#: A plate's force column: OpenSim writes ``<p>ground_force_vx`` (subject01, Hamner) or
#: ``ground_force_<side>_vx`` (Rajagopal); group 1 is the force identifier without "x".
_FORCE_COLUMN = re.compile(r"^(.*ground_force(?:_.*)?_v)x$")


def grf_prefixes(storage: Storage) -> list[str]:
    """Force identifiers (``"1_ground_force_v"``, ``"ground_force_r_v"``), in file order."""
    return [m.group(1) for c in storage.columns if (m := _FORCE_COLUMN.match(c))]


def _plate_columns(ident: str) -> tuple[str, str, str]:
    """Force, point and torque column stems of a force identifier (each + x, y, z)."""
    stem = ident[: -len("v")]  # "1_ground_force_" or "ground_force_r_"
    return ident, stem + "p", stem.replace("ground_force", "ground_torque", 1)


def _plate_name(ident: str) -> str:
    """Default plate name: the identifier's prefix and infix ("1", "r"; "0" when none)."""
    return ident.replace("ground_force", "", 1)[: -len("v")].strip("_") or "0"


def read_external_loads(path) -> dict[str, str]:
    """Map ground-force prefixes to ExternalForce names from an OpenSim ExternalLoads XML.

    Args:
        path: e.g. ``subject01_walk1_grf.xml``.

    Returns:
        force identifier -> name, e.g. ``{"ground_force_v": "right",
        "1_ground_force_v": "left"}``.
    """
    path = open_input(path)
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise InputError(f"{path}: not valid XML ({exc}).") from None
    names = {}
    for force in root.iter("ExternalForce"):
        ident = (force.findtext("force_identifier") or "").strip()
        if ident:
            names[ident] = force.get("name", ident)
    return names


def read_grf_mot(path, *, names: Mapping[str, str] | None = None,
                 axes: FileAxes | str = FileAxes.OPENSIM, length_unit: str = "m",
                 ) -> tuple[ForcePlate, ...]:
    """Read ground reactions from a MOT into lab-frame force plates, one per prefix.

    Args:
        path: the .mot file.
        names: force identifier -> plate name (e.g. from :func:`read_external_loads`); a
            plate without a name is named after its prefix or infix (``ground_force_v`` ->
            ``"0"``, ``1_ground_force_v`` -> ``"1"``, ``ground_force_r_v`` -> ``"r"``).
        axes: the file's axes (OpenSim ground is Y-up).
        length_unit: unit of the COP columns (OpenSim uses m).

    Returns:
        Force plates: force on the foot (N), COP (m), free moment (N m), lab frame,
        on a uniform time base rebuilt from the first and last times (checked).
    """
    storage = read_storage(path)
    prefixes = grf_prefixes(storage)
    if not prefixes:
        raise InputError(
            f"{path}: no ground force column ('<prefix>ground_force_vx' or "
            f"'ground_force_<side>_vx'); columns: {', '.join(storage.columns)}."
        )
    factor = length_factor(length_unit, source=str(path), field="length_unit")
    rotation = lab_rotation(axes, "+x", source=str(path))
    names = dict(names or {})
    time = storage.time
    if time.size > 2:  # time printed with few decimals: rebuild it if the steps agree
        time = uniform_time(time, (time.size - 1) / (time[-1] - time[0]), source=str(path))
    plates = []
    for ident in prefixes:
        force, point, torque = _plate_columns(ident)

        def stack(stem):
            return np.column_stack([storage.column(stem + a) for a in "xyz"])

        plate = ForcePlate(
            time=time, force=stack(force), cop=stack(point) * factor,
            free_moment=(stack(torque) if torque + "x" in storage.columns
                         else np.zeros((storage.time.size, 3))),
            name=names.get(ident, _plate_name(ident)),
        )
        for kind, values in (("force", plate.force), ("cop", plate.cop),
                             ("moment", plate.free_moment)):
            check_magnitude(values, time, kind, source=f"{path} (plate {plate.name})")
        plate = rotate_plate(plate, rotation)
        _check_vertical_force(plate, axes, source=str(path))
        plates.append(plate)
    return tuple(plates)


def _check_vertical_force(plate: ForcePlate, axes, *, source: str) -> None:
    """Refuse ground reactions whose largest component is horizontal (another up axis)."""
    vertical = np.nanmax(np.abs(plate.force[:, 2]))
    horizontal = np.nanmax(np.linalg.norm(plate.force[:, :2], axis=1))
    if horizontal > max(vertical, 50.0):
        raise InputError(
            f"{source}: plate {plate.name}'s force peaks at {horizontal:.0f} N horizontally but "
            f"{vertical:.0f} N vertically when read with axes {FileAxes(axes).value!r} (OpenSim "
            "MOT files are Y-up); the file's vertical axis looks different. Re-export it Y-up.")


def _expand(columns: Mapping[str, np.ndarray], n: int, source: str) -> dict[str, np.ndarray]:
    out = {}
    for name, values in columns.items():
        values = np.asarray(values, dtype=float)
        if values.shape[0] != n:
            raise InputError(f"{source}: column {name!r} has {values.shape[0]} rows, time {n}.")
        if values.ndim == 1:
            out[name] = values
            continue
        values = values.reshape(n, -1)
        suffixes = "xyz" if values.shape[1] == 3 else [str(i + 1) for i in range(values.shape[1])]
        for suffix, column in zip(suffixes, values.T, strict=True):
            out[f"{name}_{suffix}"] = column
    for name in out:
        if re.search(r"\s", name):
            raise InputError(f"{source}: column name {name!r} contains white space.")
    return out


#: Per thread, the tab-separated rows of the last tables written, by their exact bytes: a
#: result written both as .sto and .csv (or a motion both as kinematics3d.sto and
#: motion.mot) is formatted once.
_FORMATTED = threading.local()


def _rows(data: np.ndarray, sep: str) -> list[str]:
    """Each row of ``data`` as text, every value with 10 significant digits (%.10g)."""
    kept = _FORMATTED.__dict__.setdefault("tables", {})
    key = (data.shape, data.tobytes())
    rows = kept.get(key)
    if rows is None:
        line = "\t".join(["%.10g"] * data.shape[1])   # one format per row: 3x faster
        rows = [line % tuple(row) for row in data.tolist()]
        if len(kept) >= 4:
            kept.pop(next(iter(kept)))
        kept[key] = rows
    return rows if sep == "\t" else [row.replace("\t", sep) for row in rows]


def write_storage(path, time, columns: Mapping[str, np.ndarray], *, name: str | None = None,
                  in_degrees: bool = False, header: Mapping[str, str] | None = None,
                  protect=()) -> None:
    """Write an OpenSim-readable .sto/.mot file, whole or not at all.

    Args:
        path: output file; never an input read in this session (nor one in ``protect``).
        time: (n,) s.
        columns: label -> (n,) or (n, k) values; (n, 3) become ``label_x/_y/_z``.
        name: first header line (defaults to the file stem).
        in_degrees: value of the ``inDegrees`` header entry.
        header: further ``key=value`` entries (units, provenance); values on one line.
        protect: paths that must not be overwritten.
    """
    time = np.asarray(time, dtype=float).ravel()
    flat = _expand(columns, time.size, str(path))
    lines = [name or str(path).rsplit("/", 1)[-1].rsplit(".", 1)[0], "version=1",
             f"nRows={time.size}", f"nColumns={len(flat) + 1}",
             f"inDegrees={'yes' if in_degrees else 'no'}"]
    for key, value in (header or {}).items():
        text = f"{key}={value}"
        if "\n" in text or text.strip().lower() == "endheader":
            raise InputError(f"{path}: header entry {key!r} must be one line.")
        lines.append(text)
    lines += ["endheader", "\t".join(["time", *flat])]
    data = np.column_stack([time, *flat.values()]) if flat else time[:, None]
    lines += _rows(data, "\t")
    atomic_write_text(path, "\n".join(lines) + "\n", protect=protect)


def write_csv(path, time, columns: Mapping[str, np.ndarray], *,
              units: Mapping[str, str] | None = None, provenance: str = "", protect=()) -> None:
    """Write a CSV table with a units/provenance comment line, whole or not at all.

    Layout: ``# predgait: <provenance>``, ``# units: time=s, col=unit, ...``, a header
    row, then rows. (n, 3) columns become ``label_x/_y/_z`` and share the unit.

    Args:
        path: output file (never an input).
        time: (n,) s.
        columns: label -> (n,) or (n, k) values.
        units: label -> unit text (e.g. ``"N m"``); unnamed units are written as ``?``.
        provenance: trial, model and options in one line.
        protect: paths that must not be overwritten.
    """
    time = np.asarray(time, dtype=float).ravel()
    units = dict(units or {})
    flat = _expand(columns, time.size, str(path))
    unit_of = {}
    for label in flat:
        base = label if label in units else label.rsplit("_", 1)[0]
        unit_of[label] = units.get(base, "?")
    lines = [f"# predgait: {provenance.replace(chr(10), ' ')}",
             "# units: " + ", ".join(["time=s", *(f"{k}={v}" for k, v in unit_of.items())]),
             ",".join(["time", *flat])]
    data = np.column_stack([time, *flat.values()]) if flat else time[:, None]
    lines += _rows(data, ",")
    atomic_write_text(path, "\n".join(lines) + "\n", protect=protect)
