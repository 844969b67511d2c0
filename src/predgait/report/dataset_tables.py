"""A dataset's results for statistics: one tidy long table and mean +- SD curves.

Each gait cycle (heel strike to the next heel strike of the same foot) of each trial is
resampled to 0, 1, ..., 100 % of the cycle (linear interpolation of the frames). A cycle
holding a flagged frame (NaN: inverse kinematics on a joint limit or not converged) keeps
its NaN samples and is marked ``flagged``; the curves average over the cycles that are
not flagged (mean and sample SD, ddof = 1, with their count ``n``).
"""

from __future__ import annotations

import csv
import io
import math
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: Columns of the tidy table (one row per sample of a variable in a cycle).
TIDY = ("subject", "condition", "trial", "analysis", "side", "cycle", "percent", "variable",
        "value", "unit", "flagged")
#: Columns of the curves table.
CURVES = ("subject", "condition", "analysis", "side", "variable", "unit", "percent", "mean",
          "sd", "n")
PERCENT = np.arange(101.0)
#: Every subject of a condition together (the curves' ``subject`` column).
ALL = "all"


@dataclass(frozen=True)
class Cycle:
    """One variable over one gait cycle of one trial, at 0, 1, ..., 100 %.

    ``key``: subject, condition, trial, analysis, side; ``values`` (101,) in ``unit``
    (NaN where a flagged frame was); ``flagged``: the cycle holds a flagged frame.
    """

    key: tuple[str, str, str, str, str]
    cycle: int
    variable: str
    unit: str
    flagged: bool
    values: np.ndarray


def cycles_of(key: Mapping[str, str], time: np.ndarray,
              cycles: Sequence[tuple[float, float]],
              columns: Mapping[str, tuple[np.ndarray, str]]) -> list[Cycle]:
    """The cycles of one trial, analysis and side, resampled to % of the cycle.

    Args:
        key: subject, condition, trial, analysis, side.
        time: (n,) s, the frames' times.
        cycles: (start, end) times (s) of each gait cycle.
        columns: variable -> ((n,) values, unit).
    """
    ident = tuple(str(key[k]) for k in TIDY[:5])
    out = []
    for number, (start, end) in enumerate(cycles, start=1):
        inside = (time >= start - 1e-9) & (time <= end + 1e-9)
        if inside.sum() < 3:
            continue
        at = start + PERCENT / 100.0 * (end - start)
        flagged = any(not np.isfinite(values[inside]).all() for values, _ in columns.values())
        out += [Cycle(ident, number, name, unit, flagged,
                      np.interp(at, time[inside], values[inside]))
                for name, (values, unit) in columns.items()]
    return out


_PERCENTS = [str(p) for p in range(PERCENT.size)]


def _csv_cells(*cells) -> str:
    handle = io.StringIO()
    csv.writer(handle, lineterminator="").writerow(cells)
    return handle.getvalue()


def tidy_text(cycles: Sequence[Cycle]) -> str:
    """The tidy table's rows (no header) of ``cycles``: one line per cycle and percent.

    Values with 10 significant digits (%.10g), empty where NaN.
    """
    parts = []
    for c in cycles:
        head = _csv_cells(*c.key, c.cycle) + ","
        middle = "," + _csv_cells(c.variable) + ","
        tail = "," + _csv_cells(c.unit, int(c.flagged)) + "\n"
        values = np.asarray(c.values, dtype=float)
        if np.isnan(values).any():
            numbers = np.where(np.isnan(values), "", np.char.mod("%.10g", values))
            parts += [f"{head}{p}{middle}{v}{tail}" for p, v in enumerate(numbers)]
            continue
        head, middle, tail = (t.replace("%", "%%") for t in (head, middle, tail))
        # the lines head p middle %.10g tail for p = 0, 1, ...: one join, one format
        value = f"{middle}%.10g{tail}"
        percents = _PERCENTS if values.size == len(_PERCENTS) else map(str, range(values.size))
        rows = head + (value + head).join(percents) + value
        parts.append(rows % tuple(values.tolist()))   # one format per cycle: 3x faster
    return "".join(parts)


def cycle_arrays(cycles: Sequence[Cycle]) -> dict[str, np.ndarray]:
    """The cycles as arrays (those of ``cycles.npz``).

    ``keys`` (n, 8) str: subject, condition, trial, analysis, side, cycle, variable, unit;
    ``flagged`` (n,) bool; ``values`` (n, 101).
    """
    keys = np.array([[*c.key, str(c.cycle), c.variable, c.unit] for c in cycles], dtype=str)
    return {"keys": keys.reshape(-1, 8),
            "flagged": np.array([c.flagged for c in cycles], dtype=bool),
            "values": np.array([c.values for c in cycles], dtype=float).reshape(-1, PERCENT.size)}


def cycles_from_arrays(arrays: Mapping[str, np.ndarray]) -> list[Cycle]:
    """The cycles of :func:`cycle_arrays`' arrays."""
    return [Cycle(tuple(k[:5]), int(k[5]), str(k[6]), str(k[7]), bool(f), v)
            for k, f, v in zip(arrays["keys"], arrays["flagged"], arrays["values"],
                               strict=True)]


def write_cycles(folder: Path, cycles: Sequence[Cycle]) -> dict[str, np.ndarray]:
    """``cycles.csv`` (tidy, :data:`TIDY`) and ``cycles.npz`` (the same numbers) in ``folder``.

    Returns:
        The arrays ``cycles.npz`` holds (:func:`cycle_arrays`).
    """
    (folder / "cycles.csv").write_text(",".join(TIDY) + "\n" + tidy_text(cycles))
    arrays = cycle_arrays(cycles)
    np.savez(folder / "cycles.npz", **arrays)
    return arrays


def read_cycle_arrays(folder: Path) -> dict[str, np.ndarray]:
    """The arrays :func:`write_cycles` wrote in ``folder``."""
    with np.load(folder / "cycles.npz") as data:
        return {name: data[name] for name in ("keys", "flagged", "values")}


def read_cycles(folder: Path) -> list[Cycle]:
    """The cycles :func:`write_cycles` wrote in ``folder``."""
    return cycles_from_arrays(read_cycle_arrays(folder))


def write_rows(path: Path, header: Sequence[str], rows: Iterable[Sequence]) -> None:
    """A CSV table (``%.10g`` numbers, empty for NaN) into a staging folder."""
    def cell(value):
        if isinstance(value, float):
            return "" if math.isnan(value) else f"{value:.10g}"
        return value

    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(header)
        writer.writerows([cell(v) for v in row] for row in rows)


def mean_curves(cycles: Sequence[Cycle]) -> list[list]:
    """Mean +- SD over cycles and trials per subject and condition (and over all subjects).

    Flagged cycles are left out; ``n`` counts the cycles averaged. Rows: :data:`CURVES`.
    """
    groups: dict[tuple, list[np.ndarray]] = defaultdict(list)
    for c in cycles:
        if c.flagged:
            continue
        subject, condition, _, analysis, side = c.key
        tail = (analysis, side, c.variable, c.unit)
        groups[(subject, condition, *tail)].append(c.values)
        groups[(ALL, condition, *tail)].append(c.values)
    out = []
    for key in sorted(groups, key=lambda k: (k[0] == ALL, *k)):
        values = np.array(groups[key])
        mean = values.mean(axis=0)
        sd = values.std(axis=0, ddof=1) if len(values) > 1 else np.full(PERCENT.size, math.nan)
        out += [[*key, int(p), float(m), float(d), len(values)]
                for p, m, d in zip(PERCENT, mean, sd, strict=True)]
    return out


def read_normative(path: Path) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """A normative band file: ``variable, percent, mean, sd`` (CSV, ``#`` comments allowed).

    Returns:
        variable -> (percent, mean, sd) arrays, sorted by percent.

    Raises:
        InputError: a missing column, a value that is not a number, or SD < 0.
    """
    from predgait.errors import InputError
    from predgait.textfile import read_text

    lines = [ln for ln in read_text(path).splitlines() if ln.strip() and not ln.startswith("#")]
    reader = csv.DictReader(lines)
    need = {"variable", "percent", "mean", "sd"}
    if not need <= set(reader.fieldnames or ()):
        raise InputError(f"{path}: the normative band needs the columns "
                         f"{', '.join(sorted(need))}; line 1 has {reader.fieldnames}.")
    bands: dict[str, list] = defaultdict(list)
    for number, row in enumerate(reader, start=2):
        try:
            values = [float(row[k]) for k in ("percent", "mean", "sd")]
        except (TypeError, ValueError):
            raise InputError(f"{path}: data line {number}: percent, mean and sd must be "
                             "numbers.") from None
        if values[2] < 0 or not 0 <= values[0] <= 100:
            raise InputError(f"{path}: data line {number}: percent must be 0..100 and sd >= 0.")
        bands[row["variable"]].append(values)
    out = {}
    for name, values in bands.items():
        array = np.array(sorted(values))
        out[name] = (array[:, 0], array[:, 1], array[:, 2])
    return out
