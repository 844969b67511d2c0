"""Compiled libraries of the cache: named by the hash of their bytes, checked before loading.

A compiled library is code this process will run, read from a folder on disk, so nothing
in the cache folder is trusted until it is checked:

- Name: ``<name>-<key>-<sha>.so``. ``key`` (32 hex) hashes the caller's key (the problem,
  its options and the CasADi version: :func:`predgait.function_cache.key_of`,
  :func:`predgait.problems.solver_cache.solver_key`) with :func:`build_id` (the compiler's
  version line, the flags and the machine), so another compiler or architecture never
  meets this one's libraries; ``sha`` is the first 32 hex digits of the SHA-256 of the
  library's bytes.
- Publishing (:func:`publish`): a library is built in a uniquely named temporary folder of
  the cache, evaluated once in a child process (each of its functions at zero inputs: a
  library that crashes or hangs kills only the child and is quarantined), then renamed into
  place. Concurrent writers each rename a whole file; the names differ when the bytes
  differ.
- Loading (:func:`find`): the folder must be the user's own (owner = this user, writable
  by nobody else) and writable, else everything is solved in memory and that is said once
  per process. A library must be a regular file of the user's, not a link, whose bytes
  hash to its name; one that fails (truncated, random or modified bytes) is moved aside
  as ``.quarantine-*`` with a one-line warning, and the run solves in memory (the next
  run compiles it again). The caller quarantines a library that then fails to load
  (:func:`quarantine`; e.g. a stub of another architecture).

Between the hash check and loading, only someone who can write the user's own cache
folder could swap the file: the folder check excludes anyone but the user.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import os
import platform
import secrets
import signal
import stat
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

log = logging.getLogger(__name__)

#: Seconds a child process may take to load and evaluate a new library once.
TEST_TIMEOUT = 300.0
_WARNED: set[str] = set()


@functools.lru_cache(maxsize=4)
def _compiler_version(compiler: str) -> str:
    try:
        done = subprocess.run([compiler, "--version"], capture_output=True, text=True,
                              timeout=30)
        return (done.stdout.splitlines() or [""])[0]
    except (OSError, subprocess.SubprocessError):
        return ""


def build_id(compiler: str, flags: Sequence[str]) -> str:
    """What besides the function makes a library: compiler version, flags, machine."""
    return "\0".join([compiler, _compiler_version(compiler), *flags, sys.platform,
                      platform.machine()])


def stem(name: str, key: str, build: str) -> str:
    """``<name>-<key>`` of a library: ``key`` hashed with the :func:`build_id`."""
    digest = hashlib.sha256(f"{key}\0{build}".encode()).hexdigest()[:32]
    return f"{name}-{digest}"


def digest_of(data: bytes) -> str:
    """The 32 hex digits of SHA-256 that name a library with these bytes."""
    return hashlib.sha256(data).hexdigest()[:32]


def warn_once(what: str, message: str) -> None:
    """Log ``message`` as a warning the first time ``what`` is met in this process."""
    if what not in _WARNED:
        _WARNED.add(what)
        log.warning("%s", message)


def folder_problem(folder: Path) -> str | None:
    """Why ``folder`` cannot hold this user's libraries (None when it can).

    A missing folder is created (mode 0700). Refused: not a folder, owned by another
    user, writable by group or others, or not writable (read-only mount, permissions).
    """
    try:
        folder.mkdir(parents=True, exist_ok=True, mode=0o700)
        info = folder.stat()
    except OSError as exc:
        return f"cannot be created or read ({exc.strerror})"
    if not stat.S_ISDIR(info.st_mode):
        return "is not a folder"
    if hasattr(os, "geteuid") and info.st_uid != os.geteuid():
        return f"belongs to another user (uid {info.st_uid})"
    if info.st_mode & 0o022:
        return "is writable by other users"
    if not os.access(folder, os.W_OK | os.X_OK):
        return "is read-only"
    return None


def usable(folder: Path, switch: str) -> bool:
    """True when ``folder`` may hold libraries; else warn once that runs solve in memory."""
    problem = folder_problem(folder)
    if problem:
        warn_once(f"folder {folder}", f"predgait: the solver cache {folder} {problem}: "
                  f"solving in memory (give a folder of your own in PREDGAIT_CACHE_DIR, or "
                  f"set {switch}=off).")
    return problem is None


def _file_problem(path: Path) -> str | None:
    """Why the library ``path`` may not be loaded (None when its bytes match its name)."""
    try:
        info = path.lstat()
        if stat.S_ISLNK(info.st_mode) or not stat.S_ISREG(info.st_mode):
            return "is not a regular file"
        if hasattr(os, "geteuid") and info.st_uid != os.geteuid():
            return "belongs to another user"
        if info.st_mode & 0o022:
            return "is writable by other users"
        data = path.read_bytes()
    except OSError as exc:
        return f"cannot be read ({exc.strerror})"
    if digest_of(data) != path.stem.rsplit("-", 1)[-1]:
        return "does not match its hash (damaged or modified)"
    return None


def quarantine(path: Path, reason: str) -> None:
    """Move the library ``path`` aside (``.quarantine-*``) and say so in one line."""
    target = path.with_name(f".quarantine-{path.name}-{os.getpid()}-{secrets.token_hex(4)}")
    try:
        os.rename(path, target)
        where = f"moved to {target.name}"
    except OSError as exc:
        where = f"could not be moved aside ({exc.strerror})"
    log.warning("predgait: cached library %s %s; %s; solving in memory (the next run "
                "compiles it again).", path.name, reason, where)


def find(folder: Path, library_stem: str) -> tuple[Path | None, bool]:
    """The checked library ``<stem>-<sha>.so`` in ``folder``, newest first.

    Returns:
        ``(path, quarantined)``: the library whose bytes match its name (None if there is
        none) and whether a damaged one was quarantined on the way.
    """
    quarantined = False
    candidates = []
    for path in folder.glob(f"{library_stem}-*.so"):
        try:
            candidates.append((path.lstat().st_mtime, path))
        except OSError:
            continue
    for _, path in sorted(candidates, reverse=True):
        problem = _file_problem(path)
        if problem is None:
            return path, quarantined
        quarantine(path, problem)
        quarantined = True
    return None, quarantined


def test_in_child(library: Path, names: Sequence[str], *, timeout: float = TEST_TIMEOUT
                  ) -> str | None:
    """Load ``library`` in a child process and call each function once at zero inputs.

    Returns:
        None when every call returned; else why not (the signal that killed the child,
        its error, or the timeout).
    """
    command = [sys.executable, "-m", "predgait.cache_library", str(library), *names]
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout,
                              stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        return f"a test call did not return within {timeout:.0f} s"
    except OSError as exc:
        return f"no test process ({exc.strerror})"
    if done.returncode < 0:
        return f"a test call crashed ({signal.Signals(-done.returncode).name})"
    if done.returncode:
        last = (done.stderr.strip().splitlines() or ["exit status " + str(done.returncode)])
        return f"a test call failed ({last[-1][:200]})"
    return None


def publish(built: Path, folder: Path, library_stem: str, names: Sequence[str]) -> Path:
    """Test ``built`` in a child process, then rename it to ``<stem>-<sha>.so``.

    ``built`` must be in a private temporary folder of ``folder`` (same file system).

    Raises:
        RuntimeError: The test call crashed or failed: the library is not published but
            quarantined (``.quarantine-*``, removed by the pruning after some days).
    """
    problem = test_in_child(built, names)
    if problem:
        kept = folder / f".quarantine-{library_stem}.so-{os.getpid()}-{secrets.token_hex(4)}"
        try:
            os.replace(built, kept)
            where = f"kept as {kept.name}"
        except OSError:
            where = "removed"
        raise RuntimeError(f"{library_stem}: {problem}; not cached ({where})")
    os.chmod(built, 0o600)
    target = folder / f"{library_stem}-{digest_of(built.read_bytes())}.so"
    os.replace(built, target)
    return target


def _child(library: str, names: Sequence[str]) -> None:
    """The test call: each function of ``library`` once at zero inputs."""
    import casadi as cs

    for name in names:
        function = cs.external(name, library)
        function.call([cs.DM(function.sparsity_in(i), 0) for i in range(function.n_in())])


if __name__ == "__main__":  # the test call: python -m predgait.cache_library LIB NAME...
    _child(sys.argv[1], sys.argv[2:])
