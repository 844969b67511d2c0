"""A dataset's results for statistics: one tidy long table and mean +- SD curves.

Each gait cycle (heel strike to the next heel strike of the same foot) of each trial is
resampled to 0, 1, ..., 100 % of the cycle (linear interpolation of the frames). A cycle
holding a flagged frame (NaN: inverse kinematics on a joint limit or not converged) keeps
its NaN samples and is marked ``flagged``; the curves average over the cycles that are
not flagged (mean and sample SD, ddof = 1, with their count ``n``).
"""

from __future__ import annotations

import csv
import math
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
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


def cycle_rows(key: Mapping[str, str], time: np.ndarray, cycles: Sequence[tuple[float, float]],
               columns: Mapping[str, tuple[np.ndarray, str]]) -> list[list]:
    """Tidy rows of the cycles of one trial, analysis and side.

    Args:
        key: subject, condition, trial, analysis, side.
        time: (n,) s, the frames' times.
        cycles: (start, end) times (s) of each gait cycle.
        columns: variable -> ((n,) values, unit).
    """
    rows = []
    for number, (start, end) in enumerate(cycles, start=1):
        inside = (time >= start - 1e-9) & (time <= end + 1e-9)
        if inside.sum() < 3:
            continue
        at = start + PERCENT / 100.0 * (end - start)
        sampled = {name: np.interp(at, time[inside], values[inside])
                   for name, (values, _) in columns.items()}
        flagged = any(not np.isfinite(values[inside]).all() for values, _ in columns.values())
        for name, (_, unit) in columns.items():
            for percent, value in zip(PERCENT, sampled[name], strict=True):
                rows.append([key["subject"], key["condition"], key["trial"], key["analysis"],
                             key["side"], number, int(percent), name, float(value), unit,
                             int(flagged)])
    return rows


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


def read_rows(path: Path) -> list[dict]:
    """Rows of a tidy table written by :func:`write_rows` (value as float, NaN if empty)."""
    with path.open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    for row in rows:
        row["value"] = float(row["value"]) if row["value"] else math.nan
        row["percent"], row["cycle"] = int(row["percent"]), int(row["cycle"])
        row["flagged"] = int(row["flagged"])
    return rows


def mean_curves(rows: Sequence[Mapping]) -> list[list]:
    """Mean +- SD over cycles and trials per subject and condition (and over all subjects).

    Flagged cycles are left out; ``n`` counts the cycles averaged.
    """
    groups: dict[tuple, list[float]] = defaultdict(list)
    for row in rows:
        if row["flagged"]:
            continue
        tail = (row["analysis"], row["side"], row["variable"], row["unit"], row["percent"])
        groups[(row["subject"], row["condition"], *tail)].append(row["value"])
        groups[(ALL, row["condition"], *tail)].append(row["value"])
    out = []
    for key in sorted(groups, key=lambda k: (k[0] == ALL, *k)):
        values = np.array(groups[key])
        sd = float(values.std(ddof=1)) if values.size > 1 else math.nan
        out.append([*key, float(values.mean()), sd, int(values.size)])
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
