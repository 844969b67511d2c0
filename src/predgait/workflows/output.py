"""Result folders written whole or not at all, one run per folder.

A command writes into a hidden staging folder beside ``--out`` and renames it into place
only when everything is written; on any error (and on SIGTERM/SIGINT, which the CLI turns
into an exception) the staging folder is removed and an existing ``--out`` is left
untouched. A staging folder left by a killed run (SIGKILL, power loss) carries the dead
process' id in its name and is removed by the next run in the same folder. An existing
``--out`` is replaced only with ``--force``, and never when it is, holds or lies inside
one of the command's inputs. Folders and files honour the umask.

One run per folder: :func:`check_out` claims ``--out`` (an exclusive ``flock`` on
``.<out>.predgait-lock`` beside it, released when the run ends or dies), so a second run
to the same folder fails at once with one message; with ``--force`` it runs and waits
for the claim only to publish its result (the last one is kept whole).

``--force`` keeps the previous result until the new one is in place: the old folder is
renamed to ``.<out>.predgait-previous-<pid>-*``, the new one into place, then the old
one is removed only when it holds nothing but the files predgait wrote there (listed in
its ``.predgait-written``); otherwise it is kept whole as ``<out>.previous-<time>`` and
the run says where. A run killed between the two renames leaves the previous folder,
which the next run puts back (or disposes of the same way if a new result is in place).
"""

from __future__ import annotations

import atexit
import contextlib
import fcntl
import json
import logging
import os
import re
import secrets
import shutil
import tempfile
import time
from collections.abc import Iterable, Iterator
from pathlib import Path

from predgait.errors import InputError
from predgait.textfile import check_not_input, stage_alias

logger = logging.getLogger(__name__)

#: Staging folders are named ``.<out>.predgait-<pid>-<random>``.
_STAGE = re.compile(r"^\..*\.predgait-(\d+)-[^/]*$")
#: A previous result being replaced: ``.<out>.predgait-previous-<pid>-<random>``.
_PREVIOUS = re.compile(r"^\.(.*)\.predgait-previous-(\d+)-[^/]*$")
#: The list of the files predgait wrote in a result folder (relative path -> size).
WRITTEN = ".predgait-written"
#: Claims held by this process: real path of --out -> (lock path, open descriptor).
_CLAIMS: dict[Path, tuple[Path, int]] = {}
_WAITING: set[Path] = set()  # --out folders another run held when checked (said once)


def check_out(out: str | Path, *, force: bool = False,
              inputs: Iterable[str | Path | None] = ()) -> Path:
    """Check ``--out`` before any computation: free (or ``force``), a folder, not an input.

    Raises:
        InputError: ``out`` exists without ``force``, is a file, is/holds/lies inside an
            input, or its parent folder does not exist.
    """
    out = Path(out)
    if out.is_symlink() and not out.exists():
        raise InputError(f"{out} is a link to {os.readlink(out)}, which does not exist; "
                         "give a folder path (or remove the link).")
    if out.exists() and not force:
        raise InputError(f"{out} exists; choose another --out folder or add --force.")
    if out.exists() and not out.is_dir():
        raise InputError(f"{out} is a file; --out must be a folder.")
    check_not_input(out, [p for p in inputs if p is not None])
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"{out}: folder {parent} does not exist; create it first "
                         f"(mkdir -p {parent}).")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{out}: cannot write in {parent} (read-only); choose a writable "
                         "--out folder.")
    if not _claim(out, wait=False):
        holder = _holder(out)
        if not force:
            raise InputError(f"{out}: another predgait run{holder} is writing this folder; "
                             "wait for it, choose another --out, or add --force to replace "
                             "its result when this run ends.")
        if out.resolve() not in _WAITING:
            _WAITING.add(out.resolve())
            logger.warning("%s: another predgait run%s is writing it; this run replaces its "
                           "result when it ends (--force).", out, holder)
    return out


def _lock_path(out: Path) -> Path:
    parent = out.parent if str(out.parent) else Path(".")
    return parent / f".{out.name}.predgait-lock"


def _claim(out: Path, *, wait: bool) -> bool:
    """Claim ``out`` for this process (exclusive flock); False when another run holds it.

    The lock file is removed when the claim is released; a claimer checks that the file
    it locked is still the one at the path (else it was released meanwhile: retry).
    """
    key = out.resolve()
    if key in _CLAIMS:
        return True
    path = _lock_path(out)
    flags = os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
    while True:
        try:
            fd = os.open(path, flags, 0o644)
        except OSError as exc:
            raise InputError(f"{out}: cannot claim the folder ({path.name}: "
                             f"{exc.strerror}).") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX if wait else fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            return False
        except BaseException:
            os.close(fd)
            raise
        try:
            same = os.path.samestat(os.fstat(fd), os.lstat(path))
        except OSError:
            same = False
        if same:
            break
        os.close(fd)  # released and removed by its holder meanwhile: claim afresh
    os.ftruncate(fd, 0)
    os.write(fd, f"{os.getpid()}\n".encode())
    if not _CLAIMS:
        atexit.register(release_claims)
    _CLAIMS[key] = (path, fd)
    return True


def _holder(out: Path) -> str:
    try:
        pid = int(_lock_path(out).read_text().strip())
    except (OSError, ValueError):
        return ""
    return f" (process {pid})"


def release_claims(out: str | Path | None = None) -> None:
    """Release the claim of ``out`` (None: every claim of this process)."""
    keys = list(_CLAIMS) if out is None else [Path(out).resolve()]
    for key in keys:
        if key in _CLAIMS:
            path, fd = _CLAIMS.pop(key)
            with contextlib.suppress(OSError):
                path.unlink()  # while locked: a waiting claimer sees another file
            os.close(fd)


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
    """Remove staging folders in ``folder`` left by runs that no longer exist.

    A previous result a killed ``--force`` run had moved aside is put back when its
    folder is missing, else disposed of as after a replacement (:func:`_dispose`).
    """
    removed = []
    for path in folder.glob(".*.predgait-*"):
        previous = _PREVIOUS.match(path.name)
        if previous and path.is_dir() and not _alive(int(previous.group(2))):
            out = folder / previous.group(1)
            if not os.path.lexists(out):
                path.rename(out)
                logger.warning("%s: put back the previous result, left aside by a run that "
                               "was killed", out)
            else:
                _dispose(path, out)
            continue
        if path.name.endswith(".predgait-lock"):
            _remove_unheld_lock(path)
            continue
        match = _STAGE.match(path.name)
        if match and path.is_dir() and not _alive(int(match.group(1))):
            shutil.rmtree(path, ignore_errors=True)
            removed.append(path)
            logger.warning("removed %s, left by a run that was killed", path)
    return removed


def _remove_unheld_lock(path: Path) -> None:
    """Remove the claim file ``path`` of a killed run (one nobody holds)."""
    if path.resolve() in {lock.resolve() for lock, _ in _CLAIMS.values()}:
        return
    try:
        fd = os.open(path, os.O_RDWR | getattr(os, "O_NOFOLLOW", 0))
    except OSError:
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        if os.path.samestat(os.fstat(fd), os.lstat(path)):
            path.unlink()  # while locked: a claimer that opened it claims afresh
    except OSError:  # held by a live run (BlockingIOError), or gone
        pass
    finally:
        os.close(fd)


def _record_written(stage: Path) -> None:
    """List every file of ``stage`` (relative path -> size) in its :data:`WRITTEN`."""
    files = {p.relative_to(stage).as_posix(): p.lstat().st_size
             for p in sorted(stage.rglob("*")) if p.is_file() or p.is_symlink()}
    (stage / WRITTEN).write_text(json.dumps(files, indent=0) + "\n")


def _foreign_files(folder: Path) -> list[str]:
    """Files in a previous result that predgait did not write (or that changed size)."""
    try:
        written = json.loads((folder / WRITTEN).read_text())
    except (OSError, ValueError):
        written = None
    if not isinstance(written, dict):
        return ["(no list of the files predgait wrote)"]
    return [rel for p in sorted(folder.rglob("*")) if not p.is_dir()
            if (rel := p.relative_to(folder).as_posix()) != WRITTEN
            and written.get(rel) != p.lstat().st_size]


def _dispose(old: Path, out: Path) -> None:
    """Remove the replaced result ``old``, or keep it whole if it holds other files.

    Removed when it holds only the files predgait wrote there; else renamed to
    ``<out>.previous-<time>`` beside ``out``, and the run says where.
    """
    foreign = _foreign_files(old)
    if not foreign:
        shutil.rmtree(old, ignore_errors=True)
        return
    stamp = time.strftime("%Y%m%d-%H%M%S")
    for number in range(1000):
        keep = out.with_name(f"{out.name}.previous-{stamp}" + (f"-{number}" if number else ""))
        if not os.path.lexists(keep):
            break
    old.rename(keep)
    shown = ", ".join(foreign[:3]) + (f" and {len(foreign) - 3} more" if len(foreign) > 3
                                      else "")
    logger.warning("%s: the previous result holds files predgait did not write (%s); it "
                   "was kept whole as %s", out, shown, keep)


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
        _record_written(stage)
        _claim(out, wait=True)  # --force beside another run: publish after it
        if os.path.lexists(out) and not force:
            kept = out.with_name(f"{out.name}.new-{os.getpid()}")
            stage.rename(kept)
            raise InputError(f"{out} was created by something else while this run worked; "
                             f"its result is in {kept}.")
        if os.path.lexists(out):
            old = parent / f".{out.name}.predgait-previous-{os.getpid()}-{secrets.token_hex(6)}"
            out.rename(old)  # kept until the new result is in place
            stage.rename(out)
            _dispose(old, out)
        else:
            stage.rename(out)
    finally:
        stage_alias(stage, None)
        if stage.exists():
            shutil.rmtree(stage, ignore_errors=True)
        release_claims(out)

