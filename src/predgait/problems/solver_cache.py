"""Ipopt solvers compiled in the background and kept on disk, keyed by the structure.

Building a collocation solver generates its derivative functions (the constraint
Jacobian and the Hessian of the Lagrangian): 0.4-1.5 s per leg problem with SX, in
every process. Here a problem written in MX (the node dynamics one mapped call, so the
generated C stays ~1-2 MB whatever the grid) is generated as C by CasADi and compiled
with the system C compiler into the user's cache folder (:mod:`predgait.function_cache`),
and later runs load it in a few milliseconds; the compiled functions also evaluate faster
than CasADi's virtual machine.

Compiling takes 6-14 s per leg problem (gcc -O1, busy 2-core machine), more than the
solve it would speed up, so the run that first meets a problem does not wait for it: it
solves with the MX problem expanded to SX in memory (as with the cache off) while a
detached background process compiles the solver; a later run of the same structure loads
the library. ``PREDGAIT_COMPILE=now`` compiles in the foreground instead.

- Key: SHA-256 of the CasADi version, the solver name, the serialised NLP function
  ``(x, p) -> (f, g)`` (every constant of the problem is in it) and the Ipopt options.
- Checked before loading (:mod:`predgait.cache_library`): a library whose bytes do not
  match the hash in its name, or that fails to load, is quarantined and the run solves in
  memory with a one-line warning; so does a run whose cache folder is read-only or not
  the user's own (said once).
- Off with ``PREDGAIT_SOLVER_CACHE=off`` (or when there is no C compiler): the problem is
  then built in SX and solved in memory.
"""

from __future__ import annotations

import hashlib

import casadi as cs

from predgait import function_cache
from predgait.function_cache import FLAGS, FOLDER, SWITCH, cache_folder, compiler

__all__ = ["FLAGS", "FOLDER", "SWITCH", "cache_folder", "compiler", "enabled",
           "ipopt_solver", "solver_key", "symbol_type"]


def enabled() -> bool:
    """True unless the environment turns the cache off or there is no C compiler."""
    return function_cache.enabled() and compiler() is not None


def symbol_type() -> type:
    """The CasADi symbol type problems should be written in: MX when compiled, else SX."""
    return cs.MX if enabled() else cs.SX


def _nlp_function(nlp: dict) -> cs.Function:
    return cs.Function("nlp", [nlp["x"], nlp["p"]], [nlp["f"], nlp["g"]], ["x", "p"],
                       ["f", "g"])


def solver_key(name: str, nlp: dict, options: dict) -> str:
    """Hex SHA-256 of everything that makes the generated solver what it is."""
    digest = hashlib.sha256()
    for part in (cs.__version__, name, _nlp_function(nlp).serialize(),
                 repr(sorted(options.items()))):
        digest.update(part.encode())
    return digest.hexdigest()


def ipopt_solver(name: str, nlp: dict, options: dict) -> cs.Function:
    """``cs.nlpsol(name, "ipopt", nlp, options)``, from the compiled cache when possible.

    An MX problem with the cache on is loaded from the cache folder when its library is
    there and passes its check; else its compilation starts (in the background) and this
    run solves it expanded to SX in memory. An SX problem, or the cache off, is built in memory.

    Args:
        name: Solver name.
        nlp: ``{"x", "p", "f", "g"}`` CasADi expressions.
        options: nlpsol options (part of the key; JSON values).
    """
    if not (enabled() and isinstance(nlp["x"], cs.MX)):
        return cs.nlpsol(name, "ipopt", nlp, options)
    library = function_cache.checked_library(
        name, solver_key(name, nlp, options), lambda: _nlp_function(nlp),
        {"kind": "ipopt", "name": name, "options": options})
    if library is not None:  # checked: cached, or just compiled in the foreground
        try:
            return cs.nlpsol(name, "ipopt", str(library), options)
        except RuntimeError as exc:
            function_cache.load_failed(library, exc)
    return cs.nlpsol(name, "ipopt", _nlp_function(nlp).expand(), options)
