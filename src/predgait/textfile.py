"""A user's input files: read them as UTF-8 text, remember them, never write over them.

Every reader of a user's text file (TOML problems, TRC, MOT, CSV, URDF, JSON) goes
through :func:`read_text`, so a missing, binary, empty or non-UTF-8 file gives one
:class:`~predgait.errors.InputError` naming the file and the line, never a traceback.
Every file read is remembered, and :func:`check_not_input` refuses an output path that
is, holds or lies inside an input (``--out`` over the problem file's folder, ``-o`` on
the segment table that was read).
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from predgait.errors import InputError

_READ: set[Path] = set()
_HOLDING: set[Path] = set()   # every folder holding a file of _READ
_STAGES: dict[Path, Path] = {}  # staging folder -> the --out it becomes


def note_input(path: str | Path) -> None:
    """Remember ``path`` as an input of this process (outputs may never replace it)."""
    path = Path(path).resolve()
    _READ.add(path)
    _HOLDING.update(path.parents)


def check_not_input(out: str | Path, inputs: Iterable[str | Path] = (), *,
                    option: str = "--out") -> None:
    """Refuse an output that is, holds or lies inside an input (real paths compared).

    Args:
        out: The output file or folder.
        inputs: The command's own inputs (files or folders), besides every file read.
        option: The option that named ``out``, for the message.

    Raises:
        InputError: Naming the output and the input.
    """
    target = Path(out).resolve()
    # The files read are scanned only when one is in the way (set lookups): a batch
    # worker reads hundreds of files and writes thousands.
    in_way = target in _READ or target in _HOLDING or any(p in _READ for p in target.parents)
    read = sorted(_READ) if in_way else []
    for path in [*(Path(p).resolve() for p in inputs if p is not None), *read]:
        if path == target:
            raise InputError(f"{option} {out}: refusing to overwrite an input file ({path}); "
                             "choose another path.")
        if target in path.parents:
            raise InputError(f"{option} {out} holds the input {path}; choose another path.")
        if path in target.parents:
            raise InputError(f"{option} {out} lies inside the input folder {path}; choose a "
                             "path outside it.")


#: A C3D header block: byte 0 points to the parameter block, byte 1 is 0x50 (C3D.org,
#: "The C3D File Format User Guide", 2008, ch. 3).
C3D_KEY = 0x50
#: Where predgait takes a binary file of each kind (for the message).
BINARY_USE = {
    "a C3D file (binary motion capture)": (
        "predgait reads C3D as the marker input of 'predgait inverse' (the positional "
        "MARKERS.c3d; its force plates are read from it, so give no --grf)."),
}


#: Control bytes (not tab, newline, vertical tab, form feed or carriage return).
_CONTROL = bytes(b for b in range(32) if b < 9 or b > 13)


def binary_kind(path: Path, data: bytes) -> str | None:
    """"a C3D file (...)" or "a binary file" when ``data`` is not text, else None.

    A C3D is recognised by its header (second byte 0x50, first byte the parameter block
    number 1-127) or its ``.c3d`` name; any other file holding NUL bytes in its first 8 kB,
    or more than 30 % control bytes there, is binary (UTF-16 text included).
    """
    head = data[:8192]
    if path.suffix.lower() == ".c3d" or (len(head) >= 512 and head[1] == C3D_KEY
                                         and 1 <= head[0] <= 127 and b"\x00" in head):
        return "a C3D file (binary motion capture)"
    control = len(head) - len(head.translate(None, _CONTROL))
    if b"\x00" in head or (head and control > 0.3 * len(head)):
        return "a binary file"
    return None


def read_text(path: str | Path, *, what: str = "file", allow_empty: bool = False) -> str:
    """The text of ``path`` decoded as UTF-8 (a byte-order mark is dropped).

    Args:
        path: The file.
        what: What the file should be, for messages (e.g. "TRC marker file").
        allow_empty: Accept a file with only white space.

    Raises:
        InputError: The file is missing, a folder, binary, not UTF-8 or empty.
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{path}: is a folder; give a {what}.")
    if not path.is_file():
        raise InputError(f"{path}: {what} not found. Check the path (cwd is {Path.cwd()}).")
    note_input(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read it ({exc.strerror}).") from None
    binary = binary_kind(path, data)
    if binary:
        raise InputError(f"{path}: this is {binary}; expected here: {what}. "
                         f"{BINARY_USE.get(binary, '')}"
                         .rstrip())
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise InputError(f"{path}: line {line} is not UTF-8 text (byte 0x{data[exc.start]:02x} "
                         f"at offset {exc.start}); is this a {what}? Save it as UTF-8.") from None
    if "\x00" in text:   # a NUL past the first 8 kB
        line = text[:text.index("\x00")].count("\n") + 1
        raise InputError(f"{path}: line {line} holds a NUL byte; this is a binary file, "
                         f"not a {what}.")
    if not allow_empty and not text.strip():
        raise InputError(f"{path}: the file is empty; give a {what}.")
    return text


def stage_alias(stage: Path, out: Path | None) -> None:
    """Name files in ``stage`` after ``out`` in provenance (None forgets the stage)."""
    if out is None:
        _STAGES.pop(Path(stage).resolve(), None)
    else:
        _STAGES[Path(stage).resolve()] = Path(out)


def source_name(path: str | Path | None) -> str:
    """How provenance names an input (nothing of the installing machine).

    ``bundled:<file>`` for data shipped with predgait, the final ``--out`` path for a file
    written in a staging folder, else the path as the user gave it.
    """
    if path is None or str(path) == "":
        return ""
    path = Path(path)
    real = path.resolve()
    datasets = (Path(__file__).parent / "datasets").resolve()
    if datasets in real.parents:
        return "bundled:" + real.relative_to(datasets).as_posix()
    for stage, out in _STAGES.items():
        if stage == real or stage in real.parents:
            return str(out / real.relative_to(stage))
    return str(path)
