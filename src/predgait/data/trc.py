"""Read OpenSim TRC marker files (any length unit, tab- or space-separated)."""

from __future__ import annotations

import logging

import numpy as np

from predgait.data._io import (
    check_magnitude,
    check_marker_labels,
    duplicate_labels,
    length_factor,
    read_input,
    zeros_as_missing,
)
from predgait.data.frames import FileAxes, Forward, check_vertical, lab_rotation, rotate_markers
from predgait.data.trial import Markers, uniform_time
from predgait.errors import InputError

logger = logging.getLogger(__name__)

_N_HEADER = 5



def _is_number(text: str) -> bool:
    """Whether ``text`` reads as a float (a cut-off '1.2e' or '--3' does not)."""
    try:
        float(text)
    except ValueError:
        return False
    return True

def _split(line: str) -> list[str]:
    """Fields of a line: tab-separated if it has tabs (empty fields kept), else spaces."""
    line = line.rstrip("\r\n")
    if "\t" in line:
        return [f.strip() for f in line.split("\t")]
    return line.split()


def trc_span(path) -> tuple[float, float, int] | None:
    """The time span a TRC's header announces, from its first lines only (no full read).

    Returns:
        ``(first time s, last time s, NumFrames)``: the first data row's time and
        ``(NumFrames - 1) / DataRate`` after it; None when the first lines cannot tell
        (:func:`read_trc` then gives the message).
    """
    try:
        with open(path, "rb") as handle:
            lines = [handle.readline().decode("utf-8-sig") for _ in range(_N_HEADER + 20)]
        keys = [k for k in _split(lines[1]) if k]
        header = dict(zip(keys, [v for v in _split(lines[2]) if v], strict=False))
        rate, n_frames = float(header["DataRate"]), int(header["NumFrames"])
        row = next(line for line in lines[_N_HEADER:] if line.strip())  # blank lines skipped
        first = float(_split(row)[1])
    except (OSError, UnicodeDecodeError, KeyError, ValueError, IndexError, StopIteration):
        return None
    if not (rate > 0 and n_frames > 1 and np.isfinite(first)):
        return None
    return first, first + (n_frames - 1) / rate, n_frames


def read_trc(path, *, axes: FileAxes | str = FileAxes.OPENSIM,
             forward: Forward | str = Forward.PLUS_X) -> Markers:
    """Read a TRC marker file into lab-frame markers in metres.

    The header's ``Units`` (mm, cm or m) is applied; missing values (empty fields or
    "NaN") become NaN; blank trailing columns are ignored. The time base is rebuilt
    uniformly from ``DataRate`` (checked against the time column).

    Args:
        path: the .trc file.
        axes: the file's axes; OpenSim TRCs are Y-up ("opensim").
        forward: file axis of progression after the Z-up mapping ("+x", ..., "auto").

    Returns:
        Markers, lab frame, m.

    Raises:
        InputError: missing file, malformed header, bad number, or fewer frames than
            the header's ``NumFrames`` (a truncated file).
    """
    path, text = read_input(path, what="TRC marker file")
    lines = text.splitlines()
    if len(lines) < _N_HEADER:
        raise InputError(f"{path}: only {len(lines)} lines; a TRC file has a 5-line header.")
    # Some writers pad header fields with extra tabs: only the non-empty fields pair up.
    keys = [k for k in _split(lines[1]) if k]
    values = [v for v in _split(lines[2]) if v]
    header = dict(zip(keys, values, strict=False))
    for key in ("DataRate", "NumFrames", "NumMarkers", "Units"):
        if key not in header:
            raise InputError(f"{path}: header line 2 has no {key!r} (found {keys}).")
    try:
        rate = float(header["DataRate"])
        n_frames, n_markers = int(header["NumFrames"]), int(header["NumMarkers"])
    except ValueError as exc:
        raise InputError(f"{path}: header line 3 has a bad number ({exc}).") from None
    factor = length_factor(header["Units"], source=str(path), field="Units")
    names = [n for n in _split(lines[3])[2:] if n]
    if len(names) != n_markers:
        raise InputError(
            f"{path}: line 4 names {len(names)} markers but NumMarkers is {n_markers}."
        )
    duplicate_labels(names, source=str(path), what="marker")
    check_marker_labels(names, source=str(path), where="line 4")
    if n_markers < 1 or n_frames < 0:
        raise InputError(f"{path}: header line 3 gives NumMarkers={n_markers}, "
                         f"NumFrames={n_frames}; a TRC needs at least one marker.")
    width = 2 + 3 * n_markers
    numbered = [(number, _split(line)[:width]) for number, line in
                enumerate(lines[_N_HEADER:], start=_N_HEADER + 1) if line.strip()]
    try:   # all rows at once: empty fields and short rows are NaN
        rows = np.array([[f or "nan" for f in fields] + ["nan"] * (width - len(fields))
                         for _, fields in numbered], dtype=float).reshape(-1, width)
    except ValueError:   # the first non-numeric field, for the message
        for number, fields in numbered:
            bad = next((f for f in fields if f and not _is_number(f)), None)
            if bad is not None:
                raise InputError(f"{path}: line {number} has a non-numeric value {bad!r}.") \
                    from None
        raise
    if len(rows) < n_frames:
        raise InputError(
            f"{path}: {len(rows)} data rows but the header says NumFrames={n_frames}; "
            "the file looks truncated. Re-export it."
        )
    if len(rows) < 2:
        raise InputError(f"{path}: {len(rows)} data row(s); a trial needs at least two frames.")
    if len(rows) > n_frames:
        logger.warning("%s: %d rows, NumFrames=%d; reading all rows", path, len(rows), n_frames)
    data = rows
    if np.isnan(data[:, 1]).any():
        frame = int(np.flatnonzero(np.isnan(data[:, 1]))[0]) + 1
        raise InputError(f"{path}: data row {frame} has no time value.")
    time = uniform_time(data[:, 1], rate, source=str(path))
    xyz = zeros_as_missing(data[:, 2:].reshape(len(rows), n_markers, 3) * factor,
                           source=str(path))
    check_magnitude(xyz, time, "marker", source=str(path), names=names)
    rotation = lab_rotation(axes, forward, xyz=xyz, source=str(path))
    check_vertical(np.einsum("ij,nmj->nmi", rotation, xyz), source=str(path),
                   convention=f"axes {FileAxes(axes).value!r} (OpenSim TRC files are Y-up)",
                   unit_field=f"Units {header['Units']!r} (header line 3)")
    markers = Markers(time=time, names=tuple(names), xyz=xyz, rate=rate, source=str(path))
    return rotate_markers(markers, rotation)
