"""CasADi functions kept on disk: serialised once, compiled to C in the background.

Two things are slow to make and fast to reuse: a CasADi function built symbolically (the
leg's ADAM dynamics: 0.1-0.5 s with the ADAM import) and a function generated as C and
compiled (1-14 s with gcc). Both are kept in one cache folder, keyed by a hash of what
makes them what they are:

- :func:`stored` returns a function from its serialised file (~1 ms), building and
  writing it on a miss (:mod:`predgait.dynamics.compiled_leg`).
- :func:`compiled` returns the compiled library of a function when it is there; when it
  is not, it starts compiling it in a detached background process and returns ``None``,
  so the run that first meets a function never waits for the compiler; a later run loads
  the library. One background worker per folder compiles the queued jobs one at a time.
  :mod:`predgait.problems.solver_cache` does the same with Ipopt solvers.

Folder: ``$PREDGAIT_CACHE_DIR``, else ``$XDG_CACHE_HOME/predgait/solvers``, else
``~/.cache/predgait/solvers``. Off with ``PREDGAIT_SOLVER_CACHE=off``: nothing is read or
written there (functions are built in memory in every process). ``PREDGAIT_COMPILE=now``
compiles in the foreground instead (tests, benchmarks of the first run). CasADi is
imported only when a function is used. Files are written under unique temporary names
and renamed, so a reader finds a whole file or none. The folder is pruned when a
compilation starts: files unused for :data:`MAX_AGE_DAYS` days go, then the least
recently used ones until it holds at most :data:`MAX_BYTES`.

Nothing read from the folder is trusted unchecked (:mod:`predgait.cache_library`): a
library is named by the hash of its bytes and checked before it is loaded, tested in a
child process before it is published, and quarantined when it fails (the run then
solves in memory); a serialised function starts with the hash of the rest and is
rebuilt when they differ. A folder of another user, writable by others, or read-only
means "build and solve in memory", said once.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from predgait import cache_library

if TYPE_CHECKING:
    import casadi as cs

log = logging.getLogger(__name__)

#: Environment variable that turns the cache off ("off", "0", "no", "false").
SWITCH = "PREDGAIT_SOLVER_CACHE"
#: Environment variable naming the cache folder.
FOLDER = "PREDGAIT_CACHE_DIR"
#: Environment variable: "now" compiles in the foreground, else in the background.
WHEN = "PREDGAIT_COMPILE"
#: Compiler flags: -O1 compiles ~2x faster than -O2 for the same solve time here.
FLAGS = ("-O1", "-fPIC", "-shared")
#: Pruning bounds of the cache folder.
MAX_BYTES = 500 * 2**20
MAX_AGE_DAYS = 60
#: Quarantined libraries are kept this long for inspection, days.
QUARANTINE_DAYS = 7
#: First line of a serialised function file: this tag and the SHA-256 of the rest.
_STORED_TAG = "predgait-sha256 "
#: A background compilation marker older than this is stale (its process died), s.
STALE_AFTER = 1800.0
#: Background compilations started by this process (reaped when the next one starts).
_CHILDREN: list[int] = []


def compiler() -> str | None:
    """The C compiler (``$CC``, else gcc or cc on the PATH), None if there is none."""
    for name in (os.environ.get("CC"), "gcc", "cc"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


def enabled() -> bool:
    """True unless the environment turns the cache off."""
    return os.environ.get(SWITCH, "").strip().lower() not in ("off", "0", "no", "false")


def cache_folder() -> Path:
    """Where cached functions and libraries live (see the module docstring)."""
    if os.environ.get(FOLDER):
        return Path(os.environ[FOLDER])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "predgait" / "solvers"


def key_of(parts: Iterable[str | bytes]) -> str:
    """Hex SHA-256 (32 characters) of the parts, with the CasADi version."""
    import casadi as cs

    digest = hashlib.sha256(cs.__version__.encode())
    for part in parts:
        digest.update(part if isinstance(part, bytes) else part.encode())
        digest.update(b"\0")
    return digest.hexdigest()[:32]


def stored(name: str, key: str, build: Callable[[], cs.Function]) -> cs.Function:
    """The function ``name-key`` from the cache folder, else ``build()`` (then stored).

    ``key`` must change whenever what ``build`` makes changes (:func:`key_of`). With the
    cache off the function is built in memory.
    """
    if not (enabled() and cache_library.usable(cache_folder(), SWITCH)):
        return build()
    path = cache_folder() / f"{name}-{key}.casadi"
    function = _load_stored(path)
    if function is not None:
        _touch(path)
        return function
    function = build()
    text = function.serialize()
    digest = hashlib.sha256(text.encode()).hexdigest()
    try:
        with tempfile.NamedTemporaryFile("w", dir=path.parent, prefix=f".{path.name}.",
                                         suffix=".tmp", delete=False) as handle:
            handle.write(f"{_STORED_TAG}{digest}\n{text}")
        os.replace(handle.name, path)
    except OSError as exc:
        log.warning("function %s not stored: %s", name, exc)
    return function


def _load_stored(path: Path) -> cs.Function | None:
    """The function serialised in ``path`` if its hash line matches the rest, else None."""
    import casadi as cs

    try:
        if not path.is_file():
            return None
        head, _, text = path.read_text().partition("\n")
    except (OSError, UnicodeDecodeError):
        head, text = "", ""
    if head == _STORED_TAG + hashlib.sha256(text.encode()).hexdigest():
        try:
            return cs.Function.deserialize(text)
        except RuntimeError as exc:
            reason = str(exc).splitlines()[0][:200]
    else:
        reason = "does not match its hash (damaged, modified or of an older predgait)"
    log.warning("cached function %s %s: rebuilding it", path.name, reason)
    return None


def _touch(path: Path) -> None:
    """Mark ``path`` recently used (kept by :func:`prune`); nothing on a read-only folder."""
    with contextlib.suppress(OSError):
        path.touch()


def library_stem(name: str, key: str) -> str:
    """``<name>-<key>`` of the compiled library of ``name-key`` with this compiler."""
    return cache_library.stem(name, key, cache_library.build_id(compiler() or "cc", FLAGS))


def checked_library(name: str, key: str, function: Callable[[], cs.Function], job: dict
                    ) -> Path | None:
    """The checked library of ``name-key``; None when there is none (compilation started).

    None also (in memory) when the folder cannot hold libraries, and when a damaged
    library was just quarantined: the next run compiles it again.
    """
    folder = cache_folder()
    if not cache_library.usable(folder, SWITCH):
        return None
    stem = library_stem(name, key)
    library, quarantined = cache_library.find(folder, stem)
    if library is None and not quarantined:
        start_compiling(function(), folder / f"{stem}.so", job)
        library, _ = cache_library.find(folder, stem)
    if library is not None:
        _touch(library)  # recently used: kept by prune()
    return library


def load_failed(library: Path, exc: Exception) -> None:
    """Quarantine ``library``, which CasADi could not load (``exc``)."""
    cache_library.quarantine(library, "fails to load (" + str(exc).strip().splitlines()[0][:200]
                             + ")")


def compiled(function: cs.Function, key: str) -> cs.Function | None:
    """The compiled library of ``function`` if cached, else None (compilation started).

    The compilation runs in a background process (or now, with ``PREDGAIT_COMPILE=now``);
    None also when the cache is off, there is no compiler, the folder cannot hold
    libraries, or the library failed its check or to load (quarantined).
    """
    import casadi as cs

    if not (enabled() and compiler()):
        return None
    library = checked_library(function.name(), key, lambda: function, {"kind": "function"})
    if library is None:
        return None
    try:
        return cs.external(function.name(), str(library))
    except RuntimeError as exc:
        load_failed(library, exc)
        return None


def start_compiling(function: cs.Function, library: Path, job: dict) -> bool:
    """Compile ``function`` into ``library``: in the background unless PREDGAIT_COMPILE=now.

    With ``job["kind"] == "ipopt"`` ``function`` is an NLP ``(x, p) -> (f, g)`` and the
    library holds its Ipopt solver's functions. The job is queued in the cache folder
    (``.pending-*``) for the one background worker of the folder, started if none runs,
    which compiles the queued jobs one after the other.

    Returns:
        False when it could not be queued (or failed, in the foreground); else True.
    """
    folder = library.parent
    job_file = folder / f".pending-{library.stem}.json"
    now = os.environ.get(WHEN, "").strip().lower() == "now"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        queued = _fresh(job_file)  # queued already, or being compiled
        if not queued:
            prune(folder)
            function.save(str(job_file.with_suffix(".casadi")))
            staged = job_file.with_name(f".staged-{job_file.name}")
            staged.write_text(json.dumps({**job, "library": str(library)}))
            os.replace(staged, job_file)  # the job file last: a queued job is whole
    except (OSError, RuntimeError) as exc:  # RuntimeError: CasADi could not save
        log.warning("%s not compiled: %s", library.name, str(exc).splitlines()[0])
        return False
    if now:
        return True if queued else _run_job(job_file)
    worker = folder / ".worker"
    if _fresh(worker):
        return True
    _reap()
    try:  # detached (own session): it outlives this process; no Popen to wait for
        quiet = [(os.POSIX_SPAWN_OPEN, fd, os.devnull, os.O_RDWR, 0) for fd in (0, 1, 2)]
        worker.write_text(str(os.getpid()))
        _CHILDREN.append(os.posix_spawn(
            sys.executable, [sys.executable, "-m", "predgait.function_cache", str(folder)],
            os.environ, file_actions=quiet, setsid=True))
    except (OSError, AttributeError) as exc:  # AttributeError: no posix_spawn (Windows)
        log.warning("%s not compiled: %s", library.name, exc)
        worker.unlink(missing_ok=True)
        return False
    log.info("compiling %s in the background into %s", function.name(), library)
    return True


def _fresh(marker: Path) -> bool:
    """True when a job or worker file exists and is not stale."""
    try:
        return time.time() - marker.stat().st_mtime < STALE_AFTER
    except OSError:
        return False


def _reap() -> None:
    """Collect the finished background workers of this process (no zombies)."""
    for pid in list(_CHILDREN):
        try:
            if os.waitpid(pid, os.WNOHANG)[0]:
                _CHILDREN.remove(pid)
        except ChildProcessError:
            _CHILDREN.remove(pid)


def _work(folder: Path) -> None:
    """The background worker: compile the queued jobs of ``folder``, oldest first."""
    worker, tried = folder / ".worker", set()
    try:
        while True:
            jobs = [j for j in folder.glob(".pending-*.json") if j not in tried]
            if not jobs:
                break
            job = min(jobs, key=lambda j: j.stat().st_mtime)
            tried.add(job)
            worker.touch()
            _run_job(job)
    finally:
        worker.unlink(missing_ok=True)


def _run_job(job_file: Path) -> bool:
    """Compile the job queued as ``job_file``; remove the job's files. True on success."""
    import casadi as cs

    try:
        job = json.loads(job_file.read_text())
        function = cs.Function.load(str(job_file.with_suffix(".casadi")))
        if job["kind"] == "ipopt":
            function = cs.nlpsol(job["name"], "ipopt", function, job["options"])
        compile_into(function, Path(job["library"]))
        return True
    except (OSError, RuntimeError, KeyError, ValueError) as exc:
        log.warning("%s not compiled: %s", job_file.name, exc)
        return False
    finally:
        for path in (job_file, job_file.with_suffix(".casadi")):
            path.unlink(missing_ok=True)


def compile_into(function: cs.Function, library: Path) -> Path:
    """Generate ``function`` (a solver: its oracle and functions) as C, compile, publish.

    ``library`` is ``<folder>/<stem>.so``; the library is tested in a child process and
    published as ``<stem>-<sha of its bytes>.so`` (:func:`cache_library.publish`).

    Returns:
        The published library.

    Raises:
        RuntimeError: the compiler failed (its last message), or the test call did.
    """
    import casadi as cs

    library.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=library.parent, prefix=".build-") as tmp:
        generator = cs.CodeGenerator("generated.c", {"with_header": False})
        if function.is_a("Nlpsol", True):  # an nlpsol: its parts, loaded by name
            parts = [function.oracle()] + [function.get_function(name)
                                           for name in function.get_function()]
        else:
            parts = [function]
        for part in parts:
            generator.add(part)
        source = generator.generate(f"{tmp}/")
        built = Path(tmp) / library.name
        done = subprocess.run([compiler() or "cc", *FLAGS, source, "-o", str(built)],
                              capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"compiling failed: {done.stderr.strip()[-300:]}")
        return cache_library.publish(built, library.parent, library.stem,
                                     [part.name() for part in parts])


def prune(folder: Path, *, max_bytes: int = MAX_BYTES,
          max_age_days: float = MAX_AGE_DAYS) -> None:
    """Remove cached files unused for ``max_age_days``, then the least recently used.

    Libraries and functions alike, until the folder holds at most ``max_bytes``.
    """
    for job in [*folder.glob(".pending-*"), folder / ".worker"]:  # left by killed runs
        if job.exists() and not _fresh(job):
            job.unlink(missing_ok=True)
    for path in folder.glob(".quarantine-*"):
        with contextlib.suppress(OSError):
            if time.time() - path.lstat().st_mtime > QUARANTINE_DAYS * 86400.0:
                path.unlink()
    files = [p for p in folder.glob("*") if p.is_file() and p.suffix in (".so", ".casadi", ".npz")
             and not p.name.startswith(".")]
    now = time.time()
    files.sort(key=lambda p: p.stat().st_mtime)
    total = sum(p.stat().st_size for p in files)
    for path in files:
        old = now - path.stat().st_mtime > max_age_days * 86400.0
        if old or total > max_bytes:
            total -= path.stat().st_size
            path.unlink(missing_ok=True)


if __name__ == "__main__":  # the background worker: python -m predgait.function_cache DIR
    os.nice(5)
    _work(Path(sys.argv[1]))
