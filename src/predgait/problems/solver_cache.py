"""Ipopt solvers compiled once and kept on disk, keyed by the problem's structure.

Building a collocation solver generates its derivative functions (the constraint
Jacobian and the Hessian of the Lagrangian): 0.4-1.5 s per leg problem with SX, in
every process. Here a problem written in MX (the node dynamics one mapped call, so the
generated C stays ~1-2 MB whatever the grid) is generated as C by CasADi, compiled once
with the system C compiler into the user's cache folder, and loaded by later runs in a
few milliseconds; the compiled functions also evaluate faster than CasADi's virtual
machine. The first run pays the compilation (gcc -O1: 6-14 s per leg problem measured on a
busy 2-core machine).

- Key: SHA-256 of the CasADi version, the solver name, the serialised NLP function
  ``(x, p) -> (f, g)`` (every constant of the problem is in it) and the Ipopt options.
- Folder: ``$PREDGAIT_CACHE_DIR``, else ``$XDG_CACHE_HOME/predgait/solvers``, else
  ``~/.cache/predgait/solvers``.
- Off with ``PREDGAIT_SOLVER_CACHE=off`` (or when there is no C compiler): the problem is
  then built in SX and solved in memory, as before.
- Concurrent runs: each compiles in its own temporary folder beside the cache and renames
  its library onto the key's file name (atomic), so a reader finds a whole library or none.
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import casadi as cs

log = logging.getLogger(__name__)

#: Environment variable that turns the cache off ("off", "0", "no", "false").
SWITCH = "PREDGAIT_SOLVER_CACHE"
#: Environment variable naming the cache folder.
FOLDER = "PREDGAIT_CACHE_DIR"
#: Compiler flags: -O1 compiles ~2x faster than -O2 for the same solve time here.
FLAGS = ("-O1", "-fPIC", "-shared")


def compiler() -> str | None:
    """The C compiler (``$CC``, else gcc or cc on the PATH), None if there is none."""
    for name in (os.environ.get("CC"), "gcc", "cc"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


def enabled() -> bool:
    """True unless the environment turns the cache off or there is no C compiler."""
    off = os.environ.get(SWITCH, "").strip().lower() in ("off", "0", "no", "false")
    return not off and compiler() is not None


def symbol_type() -> type:
    """The CasADi symbol type problems should be written in: MX when compiled, else SX."""
    return cs.MX if enabled() else cs.SX


def cache_folder() -> Path:
    """Where compiled solvers live (see the module docstring)."""
    if os.environ.get(FOLDER):
        return Path(os.environ[FOLDER])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "predgait" / "solvers"


def solver_key(name: str, nlp: dict, options: dict) -> str:
    """Hex SHA-256 of everything that makes the generated solver what it is."""
    function = cs.Function("nlp", [nlp["x"], nlp["p"]], [nlp["f"], nlp["g"]])
    digest = hashlib.sha256()
    for part in (cs.__version__, name, function.serialize(), repr(sorted(options.items()))):
        digest.update(part.encode())
    return digest.hexdigest()


def ipopt_solver(name: str, nlp: dict, options: dict) -> cs.Function:
    """``cs.nlpsol(name, "ipopt", nlp, options)``, from the compiled cache when possible.

    An MX problem with the cache on is loaded from the cache folder, compiled there
    first if it is missing; an SX problem, or the cache off, is built in memory.

    Args:
        name: Solver name.
        nlp: ``{"x", "p", "f", "g"}`` CasADi expressions.
        options: nlpsol options (part of the key).
    """
    if not (enabled() and isinstance(nlp["x"], cs.MX)):
        return cs.nlpsol(name, "ipopt", nlp, options)
    folder = cache_folder()
    library = folder / f"{name}-{solver_key(name, nlp, options)[:32]}.so"
    if not library.is_file():
        solver = cs.nlpsol(name, "ipopt", nlp, options)
        try:
            _compile(solver, library)
        except (OSError, RuntimeError) as exc:  # the in-memory solver still works
            log.warning("solver %s not cached: %s", name, exc)
            return solver
    return cs.nlpsol(name, "ipopt", str(library), options)


def compiled_function(function: cs.Function) -> cs.Function:
    """``function`` (any CasADi function) loaded from the compiled cache when possible.

    The same cache as :func:`ipopt_solver`: keyed by the CasADi version and the serialised
    function, compiled once with the system compiler, loaded by later runs with
    ``cs.external``. With the cache off, or if compiling fails, ``function`` itself.
    """
    if not enabled():
        return function
    digest = hashlib.sha256()
    for part in (cs.__version__, function.name(), function.serialize()):
        digest.update(part.encode())
    library = cache_folder() / f"{function.name()}-{digest.hexdigest()[:32]}.so"
    if not library.is_file():
        try:
            _compile(function, library, functions=[function])
        except (OSError, RuntimeError) as exc:
            log.warning("function %s not cached: %s", function.name(), exc)
            return function
    return cs.external(function.name(), str(library))


def _compile(solver: cs.Function, library: Path, *, functions=None) -> None:
    """Generate the solver's functions (or ``functions``) as C, compile, rename onto ``library``.

    Raises:
        RuntimeError: the compiler failed (its last message).
    """
    library.parent.mkdir(parents=True, exist_ok=True)
    log.info("compiling %s once into %s", solver.name(), library)
    if functions is None:
        functions = [solver.oracle()] + [solver.get_function(f) for f in solver.get_function()]
    with tempfile.TemporaryDirectory(dir=library.parent, prefix=".build-") as tmp:
        generator = cs.CodeGenerator("solver.c", {"with_header": False})
        for function in functions:
            generator.add(function)
        source = generator.generate(f"{tmp}/")
        built = Path(tmp) / library.name
        done = subprocess.run([compiler(), *FLAGS, source, "-o", str(built)],
                              capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"compiling failed: {done.stderr.strip()[-300:]}")
        os.replace(built, library)
