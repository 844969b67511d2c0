"""Result folders written whole or not at all.

A command writes into a hidden staging folder beside ``--out`` and renames it into place
only when everything is written; on any error the staging folder is removed and an
existing ``--out`` is left untouched. An existing ``--out`` is replaced only with
``--force`` (and never when it holds one of the command's inputs).
"""

from __future__ import annotations

import contextlib
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from predgait.errors import InputError


@contextlib.contextmanager
def staged_output(out: str | Path, *, force: bool = False,
                  inputs: Iterable[str | Path] = ()) -> Iterator[Path]:
    """Yield a staging folder; move it to ``out`` when the block succeeds."""
    out = Path(out)
    if out.exists() and not force:
        raise InputError(f"{out} exists; choose another --out folder or add --force.")
    if out.exists() and not out.is_dir():
        raise InputError(f"{out} is a file; --out must be a folder.")
    resolved = out.resolve()
    for path in inputs:
        path = Path(path).resolve()
        if path == resolved or resolved in path.parents:
            raise InputError(f"--out {out} holds the input {path}; choose another folder.")
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"{out}: folder {parent} does not exist; create it first.")
    try:
        stage = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=parent))
    except OSError as exc:
        raise InputError(f"{out}: cannot write in {parent} ({exc.strerror}).") from None
    try:
        yield stage
        if out.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old.", dir=parent))
            out.rename(old / "previous")
            stage.rename(out)
            shutil.rmtree(old, ignore_errors=True)
        else:
            stage.rename(out)
    finally:
        if stage.exists():
            shutil.rmtree(stage, ignore_errors=True)
