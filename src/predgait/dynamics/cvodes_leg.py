"""Adaptive runs of the leg with CVODES on its CasADi right-hand side (method "cvodes").

The leg's right-hand side of :mod:`predgait.dynamics.compiled_leg` (ADAM's M and h with
the partitioned equations and the forces written on symbols) is closed over time: every
input that depends on time alone is written in CasADi too, so SUNDIALS' CVODES
(variable-order BDF with Newton iterations on the exact Jacobian, through
``casadi.integrator``) runs the whole span in one call from Python:

- a sampled history (:class:`~predgait.dynamics.drivers.SampledHistory`: the measured
  foot motion, moments, hip load, passive offset, feedback reference) becomes CasADi's
  B-spline interpolant with not-a-knot ends on the same samples, the same spline as
  SciPy's default CubicSpline and :mod:`predgait.numerics.spline` (to ~1e-14 relative),
  held at its end values outside the samples as the history is;
- a constant stays a constant; anything else (a Python function of time, the hip load
  held in the thigh frame, a torque change) is not written here: :func:`cvodes_solver`
  returns None and the engine runs SciPy's RK45 with a one-line warning.

CVODES reports the states on the output grid only (``IntegratorOptions.step`` or
``t_eval``): the engine checks divergence and events on those rows, so an event is
detected at output-grid resolution and located on their cubic Hermite interpolant,
not root-found by CVODES (:func:`predgait.dynamics.integrators.integrate`). The
derivatives on the rows (for the interpolant) come from the same right-hand side.
The steps run in CasADi's SX virtual machine (the right-hand side and the splines inlined
in one expression); tests/test_cvodes_leg.py checks runs against SciPy at tight tolerance on the
Pinocchio engine.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import casadi as cs
import numpy as np

from predgait.dynamics.drivers import Columns, Constant, LegDrivers, SampledHistory
from predgait.dynamics.integrators import GridSolverFailed, IntegratorOptions

if TYPE_CHECKING:  # FastLeg calls this module (grid_solver): its type only
    from predgait.dynamics.compiled_leg import FastLeg


class _TimeInputs:
    """The drivers' time functions written on the symbol t (None when one cannot be)."""

    def __init__(self, t: cs.SX):
        self.t, self._rows = t, {}

    def of(self, function) -> cs.SX | cs.DM | None:
        """``function(t)`` in CasADi, or None (not a sampled history or a constant)."""
        if isinstance(function, Constant):
            return cs.DM(function.value)
        if isinstance(function, Columns):
            row = self._history(function.history)
            return None if row is None else row[function.columns]
        if isinstance(function, SampledHistory):
            return self._history(function)
        return None

    def _history(self, history: SampledHistory) -> cs.SX | None:
        if id(history) not in self._rows:
            time, values = history.time, history.values
            if time.size < 3:  # linear interpolation: not written here
                return None
            spline = cs.interpolant(history.name.replace(" ", "_") or "history", "bspline",
                                    [time], values.ravel(), {"algorithm": "not_a_knot"})
            held = cs.fmin(cs.fmax(self.t, history.t0), history.t1)
            self._rows[id(history)] = spline(held)
        return self._rows[id(history)]


def time_inputs(fast: FastLeg, t: cs.SX) -> cs.SX | None:
    """The leg's inputs u(t) (the layout of :meth:`FastLeg.inputs`) on t, or None."""
    parts, drivers = _TimeInputs(t), fast.system.drivers
    constant = np.zeros(fast.nu)   # the constant inputs, summed here
    varying = []                   # (rows, sign, expression) of the others

    def put(rows, function, sign: float = 1.0) -> bool:
        if isinstance(function, Constant):
            constant[rows] += sign * function.value
            return True
        value = parts.of(function)
        varying.append((np.arange(fast.nu)[rows].tolist(), sign, value))
        return value is not None

    layout = fast.layout
    tau, hip = np.arange(fast.nu)[layout.tau], np.arange(fast.nu)[layout.hip]
    written = [put(layout.qb, drivers.prescribed_q), put(layout.vb, drivers.prescribed_qd),
               put(layout.ab, drivers.prescribed_qdd),
               *(put(tau[force.rows], force.history) for force in fast.torques)]
    if fast.passive is not None and fast.passive.offset is not None:
        written.append(put(layout.tau, fast.passive.offset, -1.0))
    if fast.hip is not None:
        written += [put(hip[:3], fast.hip.force), put(hip[3:], fast.hip.moment)]
    if fast.feedback is not None:
        fb, owner = fast.feedback, getattr(fast.feedback.reference, "__self__", None)
        if not isinstance(owner, LegDrivers) or fb.reference.__func__ is not LegDrivers.reference:
            return None
        q_ref, v_ref = parts.of(owner.reference_q), parts.of(owner.reference_qd)
        if q_ref is None or v_ref is None:
            return None
        rows, ref = np.asarray(fb.rows, dtype=int), np.arange(fast.nu)[layout.reference]
        varying += [(ref[: rows.size].tolist(), 1.0, q_ref[(rows + fb.q_offset).tolist()]),
                    (ref[rows.size:].tolist(), 1.0, v_ref[rows.tolist()])]
    if not all(written):
        return None
    constant[layout.reference.stop:] = fast.parameter_values
    u = cs.SX(constant)
    for rows, sign, value in varying:
        u[rows] = u[rows] + sign * value
    return u


class CvodesLeg:
    """``(grid, x0) -> (X, F, n_rhs)``: one CVODES run of the leg reported on ``grid``.

    X: (n+1, 4) states on the grid; F: (n+1, 4) their derivatives; n_rhs: right-hand
    sides CVODES evaluated (its ``nfevals``; Jacobians not counted).
    """

    def __init__(self, fast: FastLeg, u_of_t: cs.SX, t: cs.SX, options: IntegratorOptions):
        self.fast, self.options = fast, options
        self._x, self._t = cs.SX.sym("x", 4), t
        self._ode = fast.rhs(self._x, u_of_t)[0]   # SX: the leg and its inputs inlined

    def __call__(self, grid: np.ndarray, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
        """Run from (grid[0], x0) to grid[-1]; GridSolverFailed when CVODES stops."""
        opts = {"abstol": self.options.atol, "reltol": self.options.rtol}
        if self.options.max_step is not None:
            opts["max_step_size"] = self.options.max_step
        solver = cs.integrator("leg_cvodes", "cvodes",
                               {"x": self._x, "t": self._t, "ode": self._ode},
                               float(grid[0]), grid[1:], opts)
        try:
            xf = solver(x0=x0)["xf"]
        except RuntimeError as exc:  # CVODES' return flag is on the message's last line
            raise GridSolverFailed(str(exc).strip().splitlines()[-1]) from None
        X = np.vstack([x0, np.asarray(xf).T])
        _, _, a, _ = self.fast.recover(grid, X)
        return X, np.column_stack([X[:, 2:], a[:, 3:]]), int(solver.stats()["nfevals"])


def cvodes_solver(fast: FastLeg, options: IntegratorOptions) -> CvodesLeg | None:
    """The CVODES grid solver of the leg, or None when a driver is not written here."""
    t = cs.SX.sym("t")
    u_of_t = time_inputs(fast, t)
    return None if u_of_t is None else CvodesLeg(fast, u_of_t, t, options)
