"""The leg's right-hand side and fixed-step integration as CasADi functions (fast path).

The engine's leg (:class:`predgait.dynamics.forward.LegSystem`: foot prescribed, ankle
and knee free) evaluated through Pinocchio costs ~24 us per right-hand side from Python,
so 1 s of re-synthesis (modified Euler, 1 ms, 10 iterations: 10 000 right-hand sides)
takes ~0.25 s. Here the same right-hand side is written in CasADi on ADAM's M and h of
the same URDF (the partitioned equations of :func:`~predgait.dynamics.partitioned.
free_accelerations`; the applied forces of :mod:`predgait.dynamics.forces` written on
symbols: joint torques, passive elements through the one joint-sign table, PD feedback,
the hip load in the lab or the thigh frame), and a whole fixed-step integration step
(Euler, modified Euler, RK4: the formulas of :mod:`predgait.dynamics.integrators`) is
mapped over 100 steps per call, so Python is called once per 100 steps:

- inputs that depend on time alone (the prescribed foot motion, torques, hip load, the
  passive offset, the feedback reference) are sampled by the engine's own functions at
  the step times, in Python, once per time;
- the steps run in CasADi's virtual machine, or in the compiled library once it is in
  the cache (:mod:`predgait.function_cache`: compiled in the background the first time a
  structure is met, ~1 s of gcc; the forces' numbers are inputs, so one library
  serves every value of the passive parameters and gains);
- the base dynamics ``leg_dynamics`` (ADAM, 0.1-0.5 s to build with its import) are stored
  serialised in the same cache, keyed by the URDF and gravity.

tests/test_compiled_leg.py checks the right-hand side and whole runs against the
Pinocchio engine, which stays the reference and the fallback (cache off, another
integrator, other forces).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from typing import ClassVar

import casadi as cs
import numpy as np

from predgait import function_cache
from predgait.dynamics.drivers import sample
from predgait.dynamics.forces import FrameLoad, JointFeedback, JointTorques, PassiveTorques
from predgait.dynamics.integrators import IntegratorOptions, Method
from predgait.dynamics.partitioned import free_accelerations
from predgait.kinematics.clinical import clinical_joint
from predgait.models.loading import Model

#: Steps per call of the mapped step function.
CHUNK = 100
#: Version of what :func:`leg_dynamics` builds (part of its cache key).
VERSION = "1"
FREE, PRESCRIBED = [3, 4], [0, 1, 2]
#: Step and output functions of this process, by structure key (compiled or in the VM).
_STEPS: dict[str, cs.Function] = {}


@dataclasses.dataclass(frozen=True)
class InputLayout:
    """Rows of the leg's input vector u (:meth:`FastLeg.inputs`, :attr:`FastLeg.rhs`).

    qb, vb, ab (3 each): the prescribed foot coordinates, rates, accelerations; tau (5):
    applied generalised forces; hip (6): the hip force (N) and moment (N m); reference
    (2 per feedback row): the PD reference angles then rates; the forces' parameters
    (:attr:`FastLeg.parameter_values`) from ``reference.stop`` on.
    """

    reference: slice
    qb: ClassVar[slice] = slice(0, 3)
    vb: ClassVar[slice] = slice(3, 6)
    ab: ClassVar[slice] = slice(6, 9)
    tau: ClassVar[slice] = slice(9, 14)
    hip: ClassVar[slice] = slice(14, 20)


@functools.lru_cache(maxsize=4)
def leg_dynamics(model: Model) -> cs.Function:
    """``leg_dynamics(x, qb, vb, ab, tau, hip_lab, hip_body) -> (xdot, reaction)``.

    x: (4,) ankle, knee angles and rates; qb, vb, ab: (3,) prescribed foot coordinates,
    rates, accelerations; tau: (5,) applied generalised forces besides the hip load;
    hip_lab, hip_body: (6,) force (N) and moment (N m) at frame ``hip_center``, on the lab
    axes and on the frame's own axes (Pinocchio's LOCAL_WORLD_ALIGNED and LOCAL
    Jacobians). xdot: (4,); reaction: (3,) what the prescribed foot rows supply,
    RNEA(q, v, a)_p - tau_p (the engine's ``reaction``).
    """
    key = function_cache.key_of(["leg_dynamics", VERSION, model.urdf, repr(model.gravity)])
    return function_cache.stored("leg_dynamics", key, lambda: _build_leg_dynamics(model))


def _build_leg_dynamics(model: Model) -> cs.Function:
    from predgait.models.symbolic import base_transform, symbolic_model

    sym = symbolic_model(model)
    x, qb, vb, ab = cs.SX.sym("x", 4), cs.SX.sym("qb", 3), cs.SX.sym("vb", 3), cs.SX.sym("ab", 3)
    tau, hip_lab, hip_body = cs.SX.sym("tau", 5), cs.SX.sym("hip_lab", 6), cs.SX.sym("hip_body", 6)
    q, v = cs.vertcat(qb, x[:2]), cs.vertcat(vb, x[2:])
    frame = sym.kindyn.forward_kinematics("hip_center", base_transform(q[:3]), q[3:])
    point, rotation = frame[:3, 3], frame[:3, :3]
    thigh = clinical_joint(model, "hip").coordinates  # rows turning the thigh about +Y
    pitch = sum(q[model.coordinate_index(c)] for c in thigh)
    force = hip_lab[:3] + rotation @ hip_body[:3]
    moment = hip_lab[3:] + rotation @ hip_body[3:]
    applied = tau + cs.jacobian(point, q).T @ force + cs.jacobian(pitch, q).T * moment[1]
    mass, bias = sym.mass_matrix(q), sym.bias_force(q, v)
    accel = free_accelerations(mass, bias, applied, ab, FREE, PRESCRIBED)
    reaction = (mass @ cs.vertcat(ab, accel) + bias - applied)[PRESCRIBED]
    return cs.Function("leg_dynamics", [x, qb, vb, ab, tau, hip_lab, hip_body],
                       [cs.vertcat(x[2:], accel), reaction],
                       ["x", "qb", "vb", "ab", "tau", "hip_lab", "hip_body"],
                       ["xdot", "reaction"])


class FastLeg:
    """The leg system's fixed-step runs through CasADi (see the module docstring).

    Build with :func:`fast_leg` (None when the system's forces are not all supported).
    """

    def __init__(self, system, feedback: JointFeedback | None, passive: PassiveTorques | None,
                 hip: FrameLoad | None, torques: tuple):
        self.system, self.feedback, self.passive, self.hip = system, feedback, passive, hip
        self.torques = torques
        n_ref = 0 if feedback is None else len(feedback.rows)
        #: Rows of the inputs u (public: :mod:`predgait.dynamics.cvodes_leg` writes them).
        self.layout = InputLayout(reference=slice(20, 20 + 2 * n_ref))
        self._symbols: list = []      # the forces' parameters (scalars) and their values
        self.parameter_values: list[float] = []  # in the layout's last rows
        self.rhs = self._rhs_function(leg_dynamics(system.model))
        self._key = function_cache.key_of([self.rhs.serialize()])
        self._inputs = None  # (times, inputs) of the latest call
        self._recovered = None  # (t, x, rows) of the latest recover()

    # -- symbolic ---------------------------------------------------------------------
    def _parameter(self, value):
        """A parameter symbol holding the number ``value``; exactly 0 stays a constant.

        A zero is structure (e.g. :class:`~predgait.dynamics.passive.ExponentialLimits`
        without stop damping leaves that term out), as in the numeric forces.
        """
        if not isinstance(value, int | float | np.number) or value == 0:
            return value
        self._symbols.append(cs.SX.sym(f"p{len(self._symbols)}"))
        self.parameter_values.append(float(value))
        return self._symbols[-1]

    def _symbolic_joint(self, joint):
        """The passive joint with its elements' numbers as parameters (same elements)."""
        elements = tuple(
            dataclasses.replace(e, **{f.name: self._parameter(getattr(e, f.name))
                                      for f in dataclasses.fields(e)})
            if dataclasses.is_dataclass(e) else e for e in joint.elements)
        return dataclasses.replace(joint, elements=elements)

    def _rhs_function(self, base: cs.Function) -> cs.Function:
        """``leg_rhs(x, u) -> (xdot, reaction)`` with the state-dependent forces.

        The forces' numbers (passive parameters, gains) are inputs at the end of u, so
        one function (and library) serves every value of them.
        """
        lay = self.layout
        x, u_time = cs.SX.sym("x", 4), cs.SX.sym("u", lay.reference.stop)
        q, v = cs.vertcat(u_time[lay.qb], x[:2]), cs.vertcat(u_time[lay.vb], x[2:])
        tau = [u_time[lay.tau][i] for i in range(5)]
        if self.passive is not None:  # PassiveTorques.add on symbols (same table)
            for name, (rows, clinical) in self.passive.rows.items():
                joint = self._symbolic_joint(self.passive.joints[name])
                moment = clinical.generalized_force(joint.moment, sum(q[r] for r in rows),
                                                    sum(v[r] for r in rows))
                for row in rows:
                    tau[row] = tau[row] + moment
        if self.feedback is not None:  # JointFeedback.torque on symbols
            fb, ref = self.feedback, u_time[lay.reference]
            n = len(fb.rows)
            kp, kd = np.broadcast_to(fb.kp, n), np.broadcast_to(fb.kd, n)
            for i, row in enumerate(fb.rows):
                tau[row] = tau[row] + (
                    self._parameter(float(kp[i])) * (ref[i] - q[row + fb.q_offset])
                    + self._parameter(float(kd[i])) * (ref[n + i] - v[row]))
        zero = cs.SX.zeros(6)
        body = self.hip is not None and self.hip.body_fixed
        hip_lab, hip_body = (zero, u_time[lay.hip]) if body else (u_time[lay.hip], zero)
        xdot, reaction = base(x, u_time[lay.qb], u_time[lay.vb], u_time[lay.ab],
                              cs.vertcat(*tau), hip_lab, hip_body)
        self.nu = lay.reference.stop + len(self._symbols)
        u = cs.vertcat(u_time, *self._symbols)
        return cs.Function("leg_rhs", [x, u], [xdot, reaction], ["x", "u"],
                           ["xdot", "reaction"])

    def steps(self, options: IntegratorOptions) -> cs.Function:
        """``leg_steps(x0, W) -> (X, F)``: CHUNK steps; W columns (u_a, u_mid, u_b, h).

        X: states after each step; F: f at each step's start. Compiled when cached.
        """
        kind = (options.method, options.iterations if options.method is
                Method.MODIFIED_EULER else 0)
        key = function_cache.key_of([self._key, kind[0].value, str(kind[1]), str(CHUNK)])
        if key not in _STEPS:
            chunk = self._step_function(*kind).mapaccum("leg_steps", CHUNK)
            _STEPS[key] = function_cache.compiled(chunk, key) or chunk
        return _STEPS[key]

    def _step_function(self, method: Method, iterations: int) -> cs.Function:
        x, h = cs.SX.sym("x", 4), cs.SX.sym("h")
        ua, um, ub = (cs.SX.sym(name, self.nu) for name in ("ua", "um", "ub"))

        def f(state, u):
            return self.rhs(state, u)[0]

        f0 = f(x, ua)
        if method is Method.RK4:
            h2 = 0.5 * h
            k2 = f(x + h2 * f0, um)
            k3 = f(x + h2 * k2, um)
            k4 = f(x + h * k3, ub)
            x_next = x + (h / 6.0) * (f0 + k4 + 2.0 * (k2 + k3))
        elif method is Method.MODIFIED_EULER and iterations > 1:
            base, x_next = x + 0.5 * h * f0, x + h * f0
            for _ in range(iterations - 1):
                x_next = base + 0.5 * h * f(x_next, ub)
        else:
            x_next = x + h * f0
        return cs.Function("leg_step", [x, cs.vertcat(ua, um, ub, h)], [x_next, f0])

    # -- numeric ----------------------------------------------------------------------
    def inputs(self, times: np.ndarray) -> np.ndarray:
        """(n, nu) per-time inputs at ``times``, from the engine's own time functions.

        The drivers' sampled histories are evaluated at all times at once
        (:func:`~predgait.dynamics.drivers.sample`); the last result is kept.
        """
        if self._inputs is not None and np.array_equal(self._inputs[0], times):
            return self._inputs[1]
        times = np.asarray(times, dtype=float)
        lay = self.layout
        drivers, out = self.system.drivers, np.zeros((len(times), self.nu))
        out[:, lay.qb] = sample(drivers.prescribed_q, times)
        out[:, lay.vb] = sample(drivers.prescribed_qd, times)
        out[:, lay.ab] = sample(drivers.prescribed_qdd, times)
        for force in self.torques:
            out[:, lay.tau][:, force.rows] += sample(force.history, times)
        if self.passive is not None and self.passive.offset is not None:
            out[:, lay.tau] -= sample(self.passive.offset, times)
        if self.hip is not None:
            out[:, lay.hip.start:lay.hip.start + 3] = sample(self.hip.force, times)
            out[:, lay.hip.start + 3:lay.hip.stop] = sample(self.hip.moment, times)
        if self.feedback is not None:
            fb = self.feedback
            for k, t in enumerate(times):
                ref = fb.reference(t)
                out[k, lay.reference] = np.concatenate([ref[0][fb.rows + fb.q_offset],
                                                    ref[1][fb.rows]])
        out[:, lay.reference.stop:] = self.parameter_values
        self._inputs = (times, out)
        return out

    def trajectory(self, options: IntegratorOptions) -> Callable:
        """``(grid, x0) -> (X, F)`` (n+1 rows each, F = f(t, X)) for ``options``."""
        steps = self.steps(options)

        def run(grid: np.ndarray, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            n = len(grid) - 1
            u = self.inputs(grid)
            mid = (self.inputs(0.5 * (grid[:-1] + grid[1:])) if options.method is Method.RK4
                   else np.zeros((n, self.nu)))
            columns = -(-n // CHUNK) * CHUNK  # padded with steps of h = 0
            w = np.zeros((3 * self.nu + 1, columns))
            w[: self.nu, :n], w[self.nu: 2 * self.nu, :n] = u[:-1].T, mid.T
            w[2 * self.nu: 3 * self.nu, :n], w[-1, :n] = u[1:].T, np.diff(grid)
            X, F = np.empty((n + 1, 4)), np.empty((n + 1, 4))
            X[0], x = x0, x0
            for start in range(0, n, CHUNK):
                xs, fs = steps(x, w[:, start: start + CHUNK])
                stop = min(n, start + CHUNK)
                X[start + 1: stop + 1] = np.asarray(xs).T[: stop - start]
                F[start: stop] = np.asarray(fs).T[: stop - start]
                x = X[stop]
            F[n] = np.asarray(self.rhs(X[n], u[n])[0]).ravel()
            return X, F

        return run

    def grid_solver(self, options: IntegratorOptions):
        """The CVODES run of :mod:`predgait.dynamics.cvodes_leg`, or None (see there)."""
        from predgait.dynamics.cvodes_leg import cvodes_solver

        return cvodes_solver(self, options)

    def recover(self, t: np.ndarray, x: np.ndarray):
        """(q, v, a, reaction) of every output row (n, 5), (n, 5), (n, 5), (n, 3).

        The last result is kept (a CVODES run recovers its rows' rates, then the engine
        its output rows: often the same).
        """
        last = self._recovered
        if last is None or not (np.array_equal(last[0], t) and np.array_equal(last[1], x)):
            last = self._recovered = (np.array(t), np.array(x), self._recover(t, x))
        return tuple(rows.copy() for rows in last[2])

    def _recover(self, t: np.ndarray, x: np.ndarray):
        n = len(t)
        u = self.inputs(t)
        key = function_cache.key_of([self._key, "outputs", str(CHUNK)])
        if key not in _STEPS:
            mapped = self.rhs.map(CHUNK)
            _STEPS[key] = function_cache.compiled(mapped, key) or mapped
        columns = -(-n // CHUNK) * CHUNK  # padded with zero rows
        x_in, u_in = np.zeros((4, columns)), np.zeros((self.nu, columns))
        x_in[:, :n], u_in[:, :n] = x.T, u.T
        xdot, reaction = np.empty((n, 4)), np.empty((n, 3))
        for start in range(0, n, CHUNK):
            stop = min(n, start + CHUNK)
            parts = _STEPS[key](x_in[:, start: start + CHUNK], u_in[:, start: start + CHUNK])
            xdot[start:stop] = np.asarray(parts[0]).T[: stop - start]
            reaction[start:stop] = np.asarray(parts[1]).T[: stop - start]
        q = np.column_stack([u[:, self.layout.qb], x[:, :2]])
        v = np.column_stack([u[:, self.layout.vb], x[:, 2:]])
        a = np.column_stack([u[:, self.layout.ab], xdot[:, 2:]])
        bad = ~np.all(np.isfinite(x), axis=1)
        a[bad, 3:], reaction[bad] = 0.0, 0.0
        return q, v, a, reaction


def fast_leg(system) -> FastLeg | None:
    """The fast path of a :class:`~predgait.dynamics.forward.LegSystem`, or None.

    None when the cache is off (``PREDGAIT_SOLVER_CACHE=off``), the free rows are not
    ankle and knee, or a force is not one of those written here.
    """
    if not function_cache.enabled() or list(system.free) != FREE:
        return None
    parts: dict = {"feedback": None, "passive": None, "hip": None}
    torques = []
    for force in system.forces:
        if isinstance(force, JointTorques):
            torques.append(force)
        elif isinstance(force, PassiveTorques) and parts["passive"] is None:
            parts["passive"] = force
        elif (isinstance(force, JointFeedback) and parts["feedback"] is None
              and all(int(r) in FREE for r in force.rows)):
            parts["feedback"] = force
        elif (isinstance(force, FrameLoad) and force.frame == "hip_center"
              and parts["hip"] is None):
            parts["hip"] = force
        else:
            return None
    return FastLeg(system, torques=tuple(torques), **parts)
