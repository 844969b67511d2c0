"""Read marker trajectories from a plain CSV file through a column map."""

from __future__ import annotations

import csv
from collections.abc import Mapping

import numpy as np

from predgait.data._io import check_magnitude, duplicate_labels, length_factor, read_input
from predgait.data.frames import FileAxes, Forward, check_vertical, lab_rotation, rotate_markers
from predgait.data.trial import Markers, uniform_time
from predgait.errors import InputError


def read_markers_csv(path, columns: Mapping[str, tuple[str, str, str]], *,
                     time_column: str = "time", rate: float | None = None, units: str = "m",
                     axes: FileAxes | str = FileAxes.Z_UP,
                     forward: Forward | str = Forward.PLUS_X) -> Markers:
    """Read markers from a CSV with a header row, mapping columns to marker coordinates.

    Lines starting with ``#`` are comments. Empty fields and ``NaN`` become NaN.

    Args:
        path: the .csv file (comma, semicolon or tab separated; detected).
        columns: marker name -> (x, y, z) column labels, e.g.
            ``{"RHIP": ("hip_x", "hip_y", "hip_z")}``.
        time_column: label of the time column (s).
        rate: Hz; if None it is taken from the median time step.
        units: length unit of the coordinates (mm, cm, m).
        axes: the file's vertical convention.
        forward: file axis of progression, or "auto".

    Returns:
        Markers, lab frame, m, on a uniform time base.
    """
    path, text = read_input(path, what="CSV marker file")
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if len(lines) < 3:
        raise InputError(f"{path}: {max(len(lines) - 1, 0)} data row(s) after the header; "
                         "a trial needs a header row and at least two data rows.")
    try:
        dialect = csv.Sniffer().sniff(lines[0], delimiters=",;\t")
    except csv.Error:
        dialect = csv.excel
    rows = list(csv.reader(lines, dialect))
    labels = [lb.strip() for lb in rows[0]]
    duplicate_labels(labels, source=str(path))
    factor = length_factor(units, source=str(path), field="units")

    def column(label: str) -> int:
        if label not in labels:
            raise InputError(f"{path}: no column {label!r}. Columns: {', '.join(labels)}.")
        return labels.index(label)

    wanted = [column(time_column)]
    for name, triple in columns.items():
        if len(triple) != 3:
            raise InputError(f"{path}: marker {name!r} maps to {triple}; give (x, y, z) labels.")
        wanted += [column(label) for label in triple]
    cells = [[(row[index].strip() if index < len(row) else "") or "nan" for index in wanted]
             for row in rows[1:]]
    try:   # all cells at once (NumPy parses each as float() does); empty ones are NaN
        data = np.array(cells, dtype=float).reshape(len(cells), len(wanted))
    except ValueError:   # the first bad cell, for the message
        for r, row in enumerate(cells):
            for c, text in enumerate(row):
                try:
                    float(text)
                except ValueError:
                    raise InputError(
                        f"{path}: row {r + 2}, column {labels[wanted[c]]!r}: {text!r} is not a "
                        "number.") from None
        raise
    time = data[:, 0]
    if np.isnan(time).any():
        raise InputError(f"{path}: time column {time_column!r} has empty values.")
    if not np.all(np.diff(time) > 0):
        frame = int(np.flatnonzero(np.diff(time) <= 0)[0]) + 2
        raise InputError(f"{path}: time column {time_column!r} does not increase at data row "
                         f"{frame}; rows must be in time order, one per frame.")
    if rate is None:
        rate = float(1.0 / np.median(np.diff(time)))
    time = uniform_time(time, rate, source=str(path))
    xyz = data[:, 1:].reshape(len(time), len(columns), 3) * factor
    check_magnitude(xyz, time, "marker", source=str(path), names=list(columns))
    rotation = lab_rotation(axes, forward, xyz=xyz, source=str(path))
    check_vertical(np.einsum("ij,nmj->nmi", rotation, xyz), source=str(path),
                   convention=f"axes {FileAxes(axes).value!r}", unit_field=f"units {units!r}")
    markers = Markers(time=time, names=tuple(columns), xyz=xyz, rate=rate, source=str(path))
    return rotate_markers(markers, rotation)
