"""Live progress of long Ipopt solves: one line every N iterations, and each stage's name.

The command (``predgait solve``, ``predgait scenario``) turns reporting on with
:func:`reporting` (``solve --every N``); the solvers that run longer than a few seconds
(predictive 7-link gait, whole-body tracking, muscle-driven prediction) add
:func:`callback_options` to their ``nlpsol`` options when they are built and wrap each solve
in :func:`solving`, which names the stage and gives the constraint bounds. A line reads::

    stage 2/3 full stride: iter   20  objective  1.2345e+00  max constraint violation  3.1e-04

The objective is the NLP's (unscaled); the constraint violation is the largest violation
of the constraint bounds ``lbg <= g <= ubg`` at the iterate, in the constraints' own units,
the measure of ``constraint_violation`` in the results (Ipopt's own ``inf_pr``, in
``ipopt_history`` and the convergence plots, is that of its scaled problem: often 10-1000x
smaller). The objective equals the history's at the same iteration. Outside
:func:`reporting` nothing is attached and nothing printed. Library code never prints: the
command gives ``write``.
"""

from __future__ import annotations

import contextlib
import contextvars
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import numpy as np


@dataclass
class _State:
    every: int
    write: Callable[[str], None]
    label: str = ""
    lbg: np.ndarray = field(default_factory=lambda: np.zeros(0))
    ubg: np.ndarray = field(default_factory=lambda: np.zeros(0))
    calls: int = 0
    started: float = 0.0


_STATE: contextvars.ContextVar[_State | None] = contextvars.ContextVar(
    "predgait_ipopt_progress", default=None)
#: Callbacks built in this process (CasADi needs them alive as long as their solver).
_KEEP: list = []


@contextlib.contextmanager
def reporting(every: int, write: Callable[[str], None]) -> Iterator[None]:
    """Within the block, solvers built report every ``every`` iterations (0: off)."""
    token = _STATE.set(_State(every, write) if every > 0 else None)
    try:
        yield
    finally:
        _STATE.reset(token)


def active() -> bool:
    """True inside :func:`reporting` with ``every > 0``."""
    return _STATE.get() is not None


def stage(text: str) -> None:
    """Announce a stage of a multi-stage run (a line, when reporting)."""
    state = _STATE.get()
    if state is not None:
        state.write(text)


@contextlib.contextmanager
def solving(label: str, lbg=None, ubg=None) -> Iterator[None]:
    """One Ipopt solve named ``label``, constraint bounds ``lbg``/``ubg`` (scalars, arrays)."""
    state = _STATE.get()
    if state is None:
        yield
        return
    previous = (state.label, state.lbg, state.ubg, state.calls, state.started)
    state.label = label
    state.lbg = np.atleast_1d(np.asarray(-np.inf if lbg is None else lbg, dtype=float)).ravel()
    state.ubg = np.atleast_1d(np.asarray(np.inf if ubg is None else ubg, dtype=float)).ravel()
    state.calls, state.started = 0, time.perf_counter()
    state.write(f"{label}: Ipopt started")
    try:
        yield
    finally:
        state.write(f"{label}: Ipopt stopped after {max(state.calls - 1, 0)} iterations, "
                    f"{time.perf_counter() - state.started:.1f} s")
        state.label, state.lbg, state.ubg, state.calls, state.started = previous


def violation(g: np.ndarray, lbg: np.ndarray, ubg: np.ndarray) -> float:
    """Largest violation of ``lbg <= g <= ubg`` (0 when all hold)."""
    g = np.asarray(g, dtype=float).ravel()
    if g.size == 0:
        return 0.0
    low = np.broadcast_to(lbg, g.shape) if lbg.size in (1, g.size) else np.full(g.shape, -np.inf)
    high = np.broadcast_to(ubg, g.shape) if ubg.size in (1, g.size) else np.full(g.shape, np.inf)
    return float(np.max(np.maximum(np.maximum(low - g, g - high), 0.0)))


def _report(f: float, g: np.ndarray) -> None:
    state = _STATE.get()
    if state is None:
        return
    k = state.calls
    state.calls += 1
    if k % state.every == 0:
        state.write(f"  {state.label}: iter {k:4d}  objective {f:11.4e}  max constraint "
                    f"violation {violation(g, state.lbg, state.ubg):9.2e}")


def callback_options(name: str, nx: int, ng: int, np_: int = 0) -> dict:
    """Nlpsol options that report progress (``{}`` outside :func:`reporting`).

    Args:
        name: Solver name (the callback is named after it).
        nx: Number of variables of the NLP.
        ng: Number of constraints.
        np_: Number of parameters.
    """
    if not active():
        return {}
    import casadi as cs

    class _Callback(cs.Callback):
        def __init__(self):
            cs.Callback.__init__(self)
            self.construct(f"{name}_progress", {})

        def get_n_in(self):
            return cs.nlpsol_n_out()

        def get_n_out(self):
            return 1

        def get_name_in(self, i):
            return cs.nlpsol_out(i)

        def get_name_out(self, i):
            return "ret"

        def get_sparsity_in(self, i):
            size = {"x": nx, "lam_x": nx, "g": ng, "lam_g": ng, "lam_p": np_,
                    "f": 1}[cs.nlpsol_out(i)]
            return cs.Sparsity.dense(size, 1) if size else cs.Sparsity(0, 0)

        def eval(self, arg):
            names = [cs.nlpsol_out(i) for i in range(cs.nlpsol_n_out())]
            values = dict(zip(names, arg, strict=True))
            _report(float(values["f"]), np.asarray(values["g"]))
            return [0]

    callback = _Callback()
    _KEEP.append(callback)
    return {"iteration_callback": callback}
