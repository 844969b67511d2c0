"""Result folders written whole or not at all.

A command writes into a hidden staging folder beside ``--out`` and renames it into place
only when everything is written; on any error (and on SIGTERM/SIGINT, which the CLI turns
into an exception) the staging folder is removed and an existing ``--out`` is left
untouched. A staging folder left by a killed run (SIGKILL, power loss) carries the dead
process' id in its name and is removed by the next run in the same folder. An existing
``--out`` is replaced only with ``--force``, and never when it is, holds or lies inside
one of the command's inputs. Folders and files honour the umask.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from predgait.errors import InputError
from predgait.textfile import check_not_input, stage_alias

logger = logging.getLogger(__name__)

#: Staging folders are named ``.<out>.predgait-<pid>-<random>``.
_STAGE = re.compile(r"^\..*\.predgait-(\d+)-[^/]*$")


def check_out(out: str | Path, *, force: bool = False,
              inputs: Iterable[str | Path | None] = ()) -> Path:
    """Check ``--out`` before any computation: free (or ``force``), a folder, not an input.

    Raises:
        InputError: ``out`` exists without ``force``, is a file, is/holds/lies inside an
            input, or its parent folder does not exist.
    """
    out = Path(out)
    if out.exists() and not force:
        raise InputError(f"{out} exists; choose another --out folder or add --force.")
    if out.exists() and not out.is_dir():
        raise InputError(f"{out} is a file; --out must be a folder.")
    check_not_input(out, [p for p in inputs if p is not None])
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"{out}: folder {parent} does not exist; create it first "
                         f"(mkdir -p {parent}).")
    return out


def _mode(default: int) -> int:
    """``default`` permission bits with the process' umask applied."""
    mask = os.umask(0)
    os.umask(mask)
    return default & ~mask


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's live process
        return True
    return True


def remove_stale_stages(folder: Path) -> list[Path]:
    """Remove staging folders in ``folder`` left by runs that no longer exist."""
    removed = []
    for path in folder.glob(".*.predgait-*"):
        match = _STAGE.match(path.name)
        if match and path.is_dir() and not _alive(int(match.group(1))):
            shutil.rmtree(path, ignore_errors=True)
            removed.append(path)
            logger.warning("removed %s, left by a run that was killed", path)
    return removed


def _make_stage(parent: Path, name: str) -> Path:
    try:
        stage = Path(tempfile.mkdtemp(prefix=f".{name}.predgait-{os.getpid()}-", dir=parent))
    except OSError as exc:
        raise InputError(f"{parent / name}: cannot write in {parent} ({exc.strerror}).") from None
    stage.chmod(_mode(0o777))
    return stage


@contextlib.contextmanager
def staged_output(out: str | Path, *, force: bool = False,
                  inputs: Iterable[str | Path | None] = ()) -> Iterator[Path]:
    """Yield a staging folder; move it to ``out`` when the block succeeds."""
    out = check_out(out, force=force, inputs=inputs)
    inputs = [p for p in inputs if p is not None]
    parent = out.parent if str(out.parent) else Path(".")
    remove_stale_stages(parent)
    stage = _make_stage(parent, out.name)
    stage_alias(stage, out)
    try:
        yield stage
        check_not_input(out, inputs)  # again: the block may have read more inputs
        if out.exists():
            old = _make_stage(parent, f"{out.name}.old")
            out.rename(old / "previous")
            stage.rename(out)
            shutil.rmtree(old, ignore_errors=True)
        else:
            stage.rename(out)
    finally:
        stage_alias(stage, None)
        if stage.exists():
            shutil.rmtree(stage, ignore_errors=True)

