"""File helpers shared by the readers and writers: input registry and atomic writes."""

from __future__ import annotations

import logging
import os
import tempfile
from pathlib import Path

from predgait.errors import InputError
from predgait.textfile import check_not_input, note_input, read_text

#: Length units accepted in headers, with their factor to metres.
LENGTH_UNITS = {"mm": 1e-3, "millimeters": 1e-3, "cm": 1e-2, "centimeters": 1e-2,
                "m": 1.0, "meters": 1.0}


def length_factor(unit: str, *, source: str, field: str) -> float:
    """Factor from ``unit`` to metres; InputError naming the file and field if unknown."""
    key = str(unit).strip().lower()
    if key not in LENGTH_UNITS:
        raise InputError(
            f"{source}: {field} {unit!r} is not a length unit predgait knows; "
            f"use one of {', '.join(sorted(LENGTH_UNITS))}."
        )
    return LENGTH_UNITS[key]


def open_input(path) -> Path:
    """Check that an input file exists, remember it as an input, and return its Path."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: file not found. Check the path (cwd is {Path.cwd()}).")
    note_input(path)
    return path


def read_input(path, *, what: str) -> tuple[Path, str]:
    """Check, remember and read an input text file (UTF-8, not empty); returns (path, text)."""
    path = open_input(path)
    return path, read_text(path, what=what)


def duplicate_labels(labels, *, source: str, what: str = "column") -> None:
    """Refuse a header that names the same column or marker twice."""
    seen = set()
    for label in labels:
        if label in seen:
            raise InputError(f"{source}: {what} {label!r} appears twice; every {what} needs "
                             "its own name.")
        seen.add(label)


def check_marker_labels(labels, *, source: str, where: str) -> None:
    """Refuse a marker label with white space (results use labels as column names).

    Args:
        labels: The marker labels as read.
        source: The file, for the message.
        where: Where the labels are in the file (e.g. "line 4", "POINT:LABELS").
    """
    import re

    for label in labels:
        if re.search(r"\s", label):
            fixed = re.sub(r"\s+", "_", label.strip())
            raise InputError(f"{source}: {where}: marker label {label!r} contains white space; "
                             f"rename it (e.g. {fixed!r}) in the file: result tables name "
                             "their columns after the markers.")


def zeros_as_missing(xyz, *, source: str):
    """Markers (n, m, 3) with exact (0, 0, 0) positions made NaN (missing), in place.

    Several exporters write a missing marker as zeros instead of an empty field or a
    negative C3D residual; a real marker never sits exactly on the lab origin.
    """
    import numpy as np

    zero = np.all(xyz == 0.0, axis=-1)
    if zero.any():
        logging.getLogger(__name__).info("%s: %d marker positions at exactly (0, 0, 0) read "
                                         "as missing", source, int(zero.sum()))
        xyz[zero] = np.nan
    return xyz


#: Largest plausible magnitudes of measured gait data (a value beyond is a corrupt file).
LIMITS = {"marker": (1e3, "m"), "force": (1e5, "N"), "cop": (1e3, "m"), "moment": (1e5, "N m")}


def check_magnitude(values, time, kind: str, *, source: str, names=None) -> None:
    """Refuse a value beyond the plausible limit of ``kind`` (NaN = missing is allowed).

    Args:
        values: (n, ...) array, SI units, first axis = frames.
        time: (n,) s of the frames, for the message.
        kind: a key of :data:`LIMITS`.
        source: file name for the message.
        names: optional labels of the second axis (markers, plates).
    """
    import numpy as np

    limit, unit = LIMITS[kind]
    values = np.asarray(values, dtype=float)
    with np.errstate(invalid="ignore"):
        bad = np.argwhere(np.abs(values) > limit)
    if bad.size:
        frame = int(bad[0][0])
        label = ""
        if names is not None and values.ndim > 1:
            label = f" ({names[int(bad[0][1])]})"
        raise InputError(f"{source}: a {kind} value{label} at t = {time[frame]:.4g} s is "
                         f"{values[tuple(bad[0])]:.4g} {unit}, beyond any gait measurement "
                         f"(|value| <= {limit:g} {unit}); the file is corrupt or in other units.")


def check_output(path) -> Path:
    """Refuse to write over a file that was read as an input in this session."""
    path = Path(path)
    check_not_input(path, option="output")
    if not path.parent.is_dir():
        raise InputError(f"{path}: output folder {path.parent} does not exist; create it first.")
    return path


def atomic_write_text(path, text: str, *, protect=()) -> Path:
    """Write ``text`` whole or not at all: temp file in the same folder, then os.replace.

    Args:
        path: output file.
        text: content.
        protect: further paths that must not be overwritten (e.g. this job's inputs).

    Returns:
        The output Path.
    """
    path = check_output(path)
    if path.resolve() in {Path(p).resolve() for p in protect}:
        raise InputError(f"{path}: refusing to overwrite an input file; choose another path.")
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    mask = os.umask(0)
    os.umask(mask)
    os.fchmod(fd, 0o666 & ~mask)  # mkstemp makes 0600; a result file honours the umask
    try:
        with os.fdopen(fd, "w", newline="\n") as handle:
            handle.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path
