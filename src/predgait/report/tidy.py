"""Summaries as plain JSON values, and numbers formatted by their unit.

``summary.json`` of every command holds numbers, strings, booleans, null, lists and
objects only: :func:`json_ready` converts NumPy values, enums, paths and frozen
dataclasses and refuses anything else, so no Python ``repr`` (``PassiveEdit(...)``,
``array([...])``, ``'None'``) reaches a file. Floats keep 6 significant digits (the
measurements behind them have 3-4). Keys end with their unit (``_deg``, ``_s``,
``_n_m_per_kg``, ...); :func:`format_quantity` prints a value with the precision that
unit deserves (angles 0.1 deg, moments 0.01 N m/kg, times 1 ms).
"""

from __future__ import annotations

import dataclasses
import enum
import json
import math
from pathlib import Path

#: Key suffix -> (unit shown, decimals). Longest suffix wins.
UNITS = {
    "_deg": ("deg", 1), "_s": ("s", 3), "_ms": ("ms", 0), "_n_m_per_kg": ("N m/kg", 2),
    "_w_per_kg": ("W/kg", 2), "_n_m": ("N m", 1), "_n": ("N", 0), "_m": ("m", 3),
    "_mm": ("mm", 1), "_kg": ("kg", 1), "_hz": ("Hz", 1), "_j": ("J", 1),
    "_n_m_per_rad": ("N m/rad", 1), "_n_m_s_per_rad": ("N m s/rad", 2),
    "_n_s_per_m": ("N s/m", 0), "_n_per_m": ("N/m", 0), "_percent": ("%", 1),
    "_rad": ("rad", 4), "_m_per_s": ("m/s", 3), "_nm": ("N m", 1), "_nm_per_kg": ("N m/kg", 2),
}
SIGNIFICANT = 6


def _round(value: float) -> float | None:
    if not math.isfinite(value):
        return None
    if value == 0.0:
        return 0.0
    return float(f"{value:.{SIGNIFICANT}g}")


def json_ready(value):
    """``value`` as JSON values only (NaN and infinity become null).

    Converts NumPy scalars and arrays, tuples, enums (their value), paths (text) and
    dataclasses (an object of their fields); dictionary keys become text.

    Raises:
        TypeError: Any other object (it would otherwise be written as its repr).
    """
    if value is None or isinstance(value, bool | str):
        return value
    if isinstance(value, enum.Enum):
        return json_ready(value.value)
    if isinstance(value, int) and not isinstance(value, bool):
        return int(value)
    if isinstance(value, float):
        return _round(value)
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, dict):
        return {str(json_ready(k)): json_ready(v) for k, v in value.items()}
    if isinstance(value, list | tuple | set | frozenset):
        return [json_ready(v) for v in value]
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: json_ready(getattr(value, f.name)) for f in dataclasses.fields(value)}
    tolist = getattr(value, "tolist", None)  # NumPy scalars and arrays
    if callable(tolist) and type(value).__module__ == "numpy":
        return json_ready(tolist())
    raise TypeError(f"{type(value).__name__} is not a JSON value; convert it first")


def write_summary(path: str | Path, data: dict) -> dict:
    """Write ``data`` as indented JSON after :func:`json_ready`; returns what was written."""
    clean = json_ready(data)
    Path(path).write_text(json.dumps(clean, indent=2, allow_nan=False) + "\n")
    return clean


def unit_of(key: str) -> tuple[str, int] | None:
    """(unit, decimals) named by the end of ``key``, or None."""
    key = key.lower()
    best = None
    for suffix, unit in UNITS.items():
        if key.endswith(suffix) and (best is None or len(suffix) > len(best[0])):
            best = (suffix, unit)
    return best[1] if best else None


def label_of(key: str) -> str:
    """``key`` without its unit suffix, words separated: ``time_to_fall_s`` -> time to fall."""
    suffixes = [s for s in UNITS if key.lower().endswith(s)]
    if suffixes:
        key = key[:-max(len(s) for s in suffixes)]
    return key.replace("_", " ").strip()


def format_number(value: float, decimals: int | None = None) -> str:
    """A number with ``decimals`` places, or 4 significant digits when None."""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if not math.isfinite(value):
        return "n/a"
    if decimals is None:
        return f"{value:.4g}"
    text = f"{value:.{decimals}f}"
    return "0" + text[2:] if text.startswith("-0") and float(text) == 0 else text


def format_quantity(key: str, value) -> str:
    """``value`` of the field ``key`` with its unit: ``("time_to_fall_s", 0.35172)`` -> 0.352 s.

    None reads "none"; lists of numbers are formatted element-wise.
    """
    if value is None:
        return "none"
    unit = unit_of(key)
    if isinstance(value, list) and all(isinstance(v, int | float) for v in value):
        text = ", ".join(format_number(v, unit[1] if unit else None) for v in value)
        return f"{text} {unit[0]}" if unit else text
    if isinstance(value, int | float) and not isinstance(value, bool):
        text = format_number(value, unit[1] if unit else None)
        return f"{text} {unit[0]}" if unit else text
    if isinstance(value, bool):
        return "yes" if value else "no"
    return str(value)


def aligned(rows: list[tuple[str, str]], *, indent: str = "  ") -> str:
    """Lines ``label  value`` with the values in one column."""
    if not rows:
        return ""
    width = max(len(label) for label, _ in rows)
    return "\n".join(f"{indent}{label:<{width}}  {value}" for label, value in rows)
