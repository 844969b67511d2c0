"""Read a user's text file as UTF-8, with one clear error for anything else.

Every reader of a user's text file (TOML problems, TRC, MOT, CSV, URDF, JSON) goes
through :func:`read_text`, so a missing, binary, empty or non-UTF-8 file gives one
:class:`~predgait.errors.InputError` naming the file and the line, never a traceback.
"""

from __future__ import annotations

from pathlib import Path

from predgait.errors import InputError


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
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read it ({exc.strerror}).") from None
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise InputError(f"{path}: line {line} is not UTF-8 text (byte 0x{data[exc.start]:02x} "
                         f"at offset {exc.start}); is this a {what}? Save it as UTF-8.") from None
    if "\x00" in text:
        line = text[:text.index("\x00")].count("\n") + 1
        raise InputError(f"{path}: line {line} holds a NUL byte; this is a binary file, "
                         f"not a {what}.")
    if not allow_empty and not text.strip():
        raise InputError(f"{path}: the file is empty; give a {what}.")
    return text
