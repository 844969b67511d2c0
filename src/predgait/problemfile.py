"""TOML problem files: load, apply ``--set key=value`` overrides, read typed fields.

Every problem file (``problems/*.toml``) is read through :class:`Table`, so errors
name the file, the key and its line, and unknown keys are refused (a typo must not be
silently ignored). Strings become enums here, at the boundary (STYLE.md 1).
"""

from __future__ import annotations

import enum
import math
import re
import tomllib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

from predgait.errors import InputError
from predgait.textfile import read_text

E = TypeVar("E", bound=enum.Enum)
_MISSING = object()


@dataclass(frozen=True)
class Table:
    """A (sub)table of a TOML problem file with where it came from."""

    data: dict
    path: Path
    text: str
    prefix: str = ""

    def _where(self, key: str) -> str:
        full = f"{self.prefix}{key}"
        line = _find_line(self.text, key, self.prefix)
        return f"{self.path}, key '{full}'" + (f" (line {line})" if line else "")

    def error(self, key: str, message: str) -> InputError:
        """An InputError that names the file, the key and its line."""
        return InputError(f"{self._where(key)}: {message}")

    def has(self, key: str) -> bool:
        """Whether the key is present."""
        return key in self.data

    def check_keys(self, allowed: Iterable[str]) -> None:
        """Refuse keys not in ``allowed`` (typos), naming the valid ones."""
        allowed = list(allowed)
        for key in self.data:
            if key not in allowed:
                raise self.error(key, f"unknown key; valid keys here: {', '.join(allowed)}.")

    def expect_command(self, command: str) -> None:
        """Refuse a problem file that belongs to another command, naming that command.

        Args:
            command: The running command ("solve", "simulate", "scenario", "sweep",
                "inverse").
        """
        owner = problem_command(self.data)
        if owner is None or owner == command:
            return
        kind = self.data.get("kind")
        what = (f"kind = {kind!r}" if isinstance(kind, str) else
                {"sweep": "a sweep ('scenario' with [grid] or [random])",
                 "scenario": "a scenario ([[edit]] / [control] tables)",
                 "inverse": "an inverse-dynamics problem ([trial] markers)",
                 "inverse --model fullbody --marker-map": "a full-body marker map ([markers])"}
                [owner])
        key = "kind" if isinstance(kind, str) else next(iter(self.data), "kind")
        raise self.error(key, f"{what} is a problem for 'predgait {owner}', not 'predgait "
                              f"{command}': run 'predgait {owner} {self.path} ...'.")

    def table(self, key: str, *, required: bool = False) -> Table:
        """A sub-table (empty if absent and not required)."""
        value = self.data.get(key, _MISSING)
        if value is _MISSING:
            if required:
                raise self.error(key, "missing table; add it (see the example files in "
                                      "problems/).")
            value = {}
        if not isinstance(value, dict):
            raise self.error(key, f"expected a table, got {type(value).__name__}.")
        return Table(value, self.path, self.text, f"{self.prefix}{key}.")

    def get(self, key: str, kind: type | tuple[type, ...], default: Any = _MISSING) -> Any:
        """A value of the given Python type(s); ``default`` if absent (else required)."""
        value = self.data.get(key, _MISSING)
        if value is _MISSING:
            if default is _MISSING:
                raise self.error(key, "missing; this key is required.")
            return default
        kinds = kind if isinstance(kind, tuple) else (kind,)
        if float in kinds and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if not isinstance(value, kinds) or (isinstance(value, bool) and bool not in kinds):
            names = " or ".join(k.__name__ for k in kinds)
            raise self.error(key, f"expected {names}, got {value!r}.")
        return value

    def number(self, key: str, default: Any = _MISSING, *, low: float = -math.inf,
               high: float = math.inf, unit: str = "") -> float:
        """A finite float within [low, high]."""
        value = self.get(key, float, default)
        if value is None:
            return value
        if not math.isfinite(value) or not low <= value <= high:
            raise self.error(key, f"{_quantity(value, unit)} is outside "
                                  f"{_quantity(low, '')}..{_quantity(high, unit)}.")
        return value

    def numbers(self, key: str, default: Any = _MISSING, *, low: float = -math.inf,
                high: float = math.inf, unit: str = "", length: int | None = None,
                increasing: bool = False) -> tuple[float, ...]:
        """A list of finite floats within [low, high] (``length`` of them if given)."""
        values = self.get(key, list, default)
        if values is None:
            return values
        if length is not None and len(values) != length:
            raise self.error(key, f"expected a list of {length} numbers, got {len(values)}.")
        out = []
        for index, value in enumerate(values):
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise self.error(key, f"entry {index + 1} is {value!r}; expected a number "
                                      f"{unit}".rstrip() + ".")
            if not math.isfinite(value) or not low <= value <= high:
                raise self.error(key, f"entry {index + 1} = {_quantity(value, unit)} is outside "
                                      f"{_quantity(low, '')}..{_quantity(high, unit)}.")
            out.append(float(value))
        if increasing and any(b <= a for a, b in zip(out, out[1:], strict=False)):
            raise self.error(key, "the values must increase.")
        return tuple(out)

    def strings(self, key: str, default: Any = _MISSING) -> tuple[str, ...]:
        """A list of strings."""
        values = self.get(key, list, default)
        if values is None:
            return values
        for index, value in enumerate(values):
            if not isinstance(value, str):
                raise self.error(key, f"entry {index + 1} is {value!r}; expected a string.")
        return tuple(values)

    def tables(self, key: str) -> list[Table]:
        """The tables of an array of tables ``[[key]]`` (empty if absent)."""
        items = self.data.get(key, [])
        if isinstance(items, dict):
            items = [items]
        if not isinstance(items, list) or not all(isinstance(i, dict) for i in items):
            raise self.error(key, f"expected tables [[{self.prefix}{key}]], got {items!r}.")
        return [Table(item, self.path, self.text, f"{self.prefix}{key}.{index}.")
                for index, item in enumerate(items)]

    def choice(self, key: str, enum_type: type[E], default: Any = _MISSING) -> E:
        """An enum member from its string value."""
        value = self.get(key, str, default)
        if isinstance(value, enum_type):
            return value
        for member in enum_type:
            if member.value == value:
                return member
        valid = ", ".join(str(m.value) for m in enum_type)
        raise self.error(key, f"{value!r} is not one of: {valid}.")

    def path_value(self, key: str, default: Any = _MISSING) -> Path | None:
        """A path, relative paths taken from the problem file's folder."""
        value = self.get(key, str, default)
        if value is None:
            return None
        path = Path(value)
        return path if path.is_absolute() else (self.path.parent / path)


def _quantity(value: float, unit: str) -> str:
    """``value`` as the user would write it (``1e+06``, ``0.05``, ``10``), then its unit."""
    text = f"{value:.12g}" if math.isfinite(value) else str(value)
    return f"{text} {unit}" if unit else text


def _find_line(text: str, key: str, prefix: str) -> int | None:
    """Line number of ``key`` inside its ``[section]`` (the n-th ``[[array]]`` for an index)."""
    lines = text.splitlines()
    start = 0
    names: list[str] = []
    for part in filter(None, prefix.split(".")):
        if part.isdigit():
            header = re.compile(rf"^\s*\[\[\s*{re.escape('.'.join(names))}\s*\]\]")
            hits = [n for n in range(start, len(lines)) if header.match(lines[n])]
            if int(part) < len(hits):
                start = hits[int(part)]
        else:
            names.append(part)
    section = ".".join(names)
    if section and not prefix.rstrip(".").split(".")[-1].isdigit():
        header = re.compile(rf"^\s*\[+\s*{re.escape(section)}\s*\]+")
        start = next((n for n in range(start, len(lines)) if header.match(lines[n])), start)
    dotted = f"{section}.{key}" if section else key
    key_pattern = re.compile(rf"^\s*\"?{re.escape(key)}\"?\s*=|^\s*\[+\s*{re.escape(dotted)}\b")
    for number in range(start, len(lines)):
        if key_pattern.match(lines[number]):
            return number + 1
    return _find_nested_line(lines, names, key, start)


def _find_nested_line(lines: list[str], names: list[str], key: str, start: int) -> int | None:
    """Line of a dotted key (``knee.k = 1``) or a key in an inline table (``knee = {k = 1}``).

    Searched below the deepest ``[section]`` of ``names`` that the file has, up to the next
    section header.
    """
    def quoted(part: str) -> str:
        return rf"\"?{re.escape(part)}\"?"

    for depth in range(len(names), -1, -1):
        section, rest = ".".join(names[:depth]), [*names[depth:], key]
        first = start
        if section:
            header = re.compile(rf"^\s*\[+\s*{re.escape(section)}\s*\]+")
            first = next((n + 1 for n in range(start, len(lines)) if header.match(lines[n])),
                         None)
            if first is None:
                continue
        dotted = re.compile(r"^\s*" + r"\s*\.\s*".join(map(quoted, rest)) + r"\s*=")
        inline = re.compile(r"^\s*" + r"\s*\.\s*".join(map(quoted, rest[:1])) + r"\s*=.*[{,]\s*"
                            + quoted(key) + r"\s*=")
        for number in range(first, len(lines)):
            if number > first and re.match(r"^\s*\[", lines[number]):
                break
            if dotted.match(lines[number]) or (len(rest) > 1 and inline.match(lines[number])):
                return number + 1
    return None


def _set_override(data: dict, assignment: str, path: Path) -> None:
    if "=" not in assignment:
        raise InputError(f"--set {assignment!r}: expected KEY=VALUE, e.g. passive.knee.k=100.")
    key, raw = (part.strip() for part in assignment.split("=", 1))
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    node = data
    parts = key.split(".")
    for part in parts[:-1]:
        if isinstance(node, list):
            if not part.isdigit() or int(part) >= len(node):
                raise InputError(f"--set {assignment!r}: {path} has {len(node)} entries there; "
                                 f"'{part}' is not an index 0..{len(node) - 1}.")
            node = node[int(part)]
        else:
            node = node.setdefault(part, {})
        if not isinstance(node, dict | list):
            raise InputError(f"--set {assignment!r}: '{part}' in {path} is not a table.")
    if isinstance(node, list):
        raise InputError(f"--set {assignment!r}: '{parts[-1]}' needs a key after the index.")
    node[parts[-1]] = value


#: The command that runs each problem ``kind`` (the file's top-level ``kind`` key).
COMMAND_KINDS = {
    "solve": ("knee_fit", "torque_correction", "feedback_gains", "passive_decomposition",
              "passive_shooting", "passive_swing", "passive_knee_ankle", "torque_feedback",
              "predict_gait7",
              "predict_muscles_2d", "fullbody_tracking"),
    "simulate": ("rod", "collapse", "resynthesis", "gait7", "fullbody"),
    "scenario": ("muscle_scenario",),
}


def problem_command(data: dict) -> str | None:
    """The predgait command a problem file's contents belong to (None: not recognised).

    By its top-level ``kind`` (:data:`COMMAND_KINDS`); without one, a sweep has
    ``scenario`` and ``[grid]``/``[random]``, a batch dataset ``[[subjects]]`` and
    ``[[trials]]``, a leg scenario ``[[edit]]`` or ``[control]``,
    an inverse problem ``[trial]`` with ``markers``, a marker map a ``[markers]`` table.
    """
    kind = data.get("kind")
    if isinstance(kind, str):
        return next((c for c, kinds in COMMAND_KINDS.items() if kind in kinds), None)
    if "scenario" in data and ("grid" in data or "random" in data):
        return "sweep"
    if "subjects" in data and "trials" in data:
        return "batch"
    if "edit" in data or "control" in data:
        return "scenario"
    if isinstance(data.get("trial"), dict) and "markers" in data["trial"]:
        return "inverse"
    if isinstance(data.get("markers"), dict):
        return "inverse --model fullbody --marker-map"
    return None


def load_problem(path: str | Path, overrides: Sequence[str] = ()) -> Table:
    """Read a TOML problem file and apply ``--set KEY=VALUE`` overrides.

    Raises:
        InputError: Missing file, TOML syntax error (with its line) or a bad override.
    """
    path = Path(path)
    if not path.is_file() and not path.is_dir():
        raise InputError(f"{path}: problem file not found; copy one from problems/.")
    text = read_text(path, what="TOML problem file")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML ({exc}).") from None
    for assignment in overrides:
        _set_override(data, assignment, path)
    return Table(data, path, text)
