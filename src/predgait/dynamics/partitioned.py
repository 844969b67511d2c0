"""THE forward-dynamics engine: any predgait model, some coordinates prescribed.

The velocity coordinates split into free (f) and prescribed (p) ones. With Pinocchio's
mass matrix M (``pin.crba``), the inverse dynamics b = RNEA(q, v, a_p) of the prescribed
accelerations (free ones zero; b = M_:p a_p + h, h the bias forces) and the applied
generalised forces tau (:mod:`predgait.dynamics.forces`)::

    a_f      = M_ff^-1 (tau_f - b_f)                     (free accelerations)
    lambda_p = RNEA(q, v, a)_p - tau_p                   (what the prescription supplies)

With nothing prescribed this is ``pin.aba``. The rod (nothing prescribed, end loads),
the leg (foot prescribed; joint torques, passive elements, hip load, feedback; the
ground reaction is lambda_p), gait7 (contacts) and the whole body (free-flyer pelvis)
are configurations of it (:mod:`predgait.dynamics.forward`, :mod:`predgait.simulations`).
The thesis' 21-equation Newton-Euler system (Appendix A) gives the same accelerations
and ground reaction (tests/test_forward_thesis.py).

Any model: planar root (PX-PZ-RY) or free flyer. A free-flyer root is free or prescribed
as a whole (its 6 velocity rows), or only its translation is free (rows 0..2: position
free, orientation prescribed); when it is free its configuration is position (lab, m)
and unit quaternion (x, y, z, w), and its velocity is Pinocchio's (linear and angular
velocity in the pelvis frame), so ``d pos/dt = R v_lin`` and ``d quat/dt = 1/2 quat *
(omega, 0)``. The quaternion is renormalised whenever the state is read.

State: x = [q_f, v_f], q_f the configuration entries of the free joints (7 for a free
flyer), v_f their velocities.

Speed: the forces say what kinematics they read (:class:`~predgait.dynamics.forces.
Kinematics`); forward kinematics and Jacobians are computed only when one needs them,
the multipliers only when asked (:meth:`PartitionedSystem.reaction`), and one or two
free coordinates are solved in closed form.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import pinocchio as pin

from predgait.dynamics.forces import Force, Kinematics, as_force
from predgait.dynamics.integrators import (
    Event,
    IntegratorOptions,
    Method,
    Status,
    integrate,
)
from predgait.errors import InputError, SimulationDiverged
from predgait.models.loading import RigidBodyModel

__all__ = ["PartitionedSystem", "SimulationResult", "Status",
           "simulate_partitioned"]


# ------------------------------------------------------------------------ system
def _solve_small(m: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Solve a small SPD system; 1x1 and 2x2 in closed form (np.linalg.solve costs ~9 us).

    Only the upper triangle of ``m`` is read (``pin.crba`` fills that).
    """
    if rhs.size == 1:
        return rhs / m[0, 0]
    if rhs.size == 2:
        (a, b), (_, d) = m.tolist()
        r0, r1 = rhs.tolist()
        det = a * d - b * b
        return np.array([(d * r0 - b * r1) / det, (a * r1 - b * r0) / det])
    return np.linalg.solve(np.triu(m) + np.triu(m, 1).T, rhs)


def free_accelerations(mass, bias, tau, a_prescribed, free, pres):
    """a_f = M_ff^-1 (tau_f - h_f - M_fp a_p): the partitioned equations, numpy or CasADi.

    The numeric engine evaluates them through Pinocchio (RNEA, CRBA or ABA); the CasADi
    problems build them from ADAM's M and h with this function (:mod:`predgait.problems.
    collocation`), on the same free and prescribed rows.

    Args:
        mass: (nv, nv) M.
        bias: (nv,) h.
        tau: (nv,) applied generalised forces.
        a_prescribed: (len(pres),) prescribed accelerations.
        free: Free rows.
        pres: Prescribed rows.
    """
    from predgait.dynamics.backend import is_casadi

    if is_casadi(mass, bias, tau, a_prescribed):
        import casadi as cs

        rhs = tau[free] - bias[free] - mass[free, pres] @ a_prescribed
        return cs.solve(mass[free, free], rhs)
    m = np.asarray(mass)
    rhs = tau[free] - bias[free] - m[np.ix_(free, pres)] @ a_prescribed
    return np.linalg.solve(m[np.ix_(free, free)], rhs)


class PartitionedSystem:
    """x' = f(t, x) for a model with the coordinates outside ``free`` prescribed.

    Args:
        model: Any predgait model (planar root or free flyer).
        free: Velocity indices integrated (for a free-flyer root: all of 0..5, only the
            translation 0..2, or none).
        motion: t -> (q, v, a) full vectors; the prescribed entries are used (e.g.
            :class:`~predgait.dynamics.motion.MotionHistory`). The free entries are ignored.
        forces: Applied forces (:mod:`predgait.dynamics.forces`; a plain function
            ``(t, q, v, data) -> (nv,)`` is accepted too).
    """

    def __init__(self, model: RigidBodyModel, free: Sequence[int],
                 motion: Callable[[float], tuple[np.ndarray, np.ndarray, np.ndarray]],
                 forces: Sequence[Force] = ()):
        pm = model.pin_model
        self.model, self.pm, self.data = model, pm, pm.createData()
        self.motion, self.forces = motion, tuple(as_force(f) for f in forces)
        self.needs = max((f.needs for f in self.forces), default=Kinematics.NONE)
        free = sorted({int(i) for i in free})
        if not free or free[0] < 0 or free[-1] >= pm.nv:
            raise InputError(f"free velocity indices {free} must be within 0..{pm.nv - 1}.")
        self.free_flyer = pm.nq != pm.nv
        root = len(set(free) & set(range(6))) if self.free_flyer else 0
        if root not in (0, 6) and set(free) & set(range(6)) != {0, 1, 2}:
            raise InputError("the free-flyer pelvis is free or prescribed as a whole "
                             "(velocity rows 0..5), or only its translation is free "
                             "(rows 0..2).")
        self.root_free = root == 6
        self.root_v = root  # free root velocity rows: 0, 3 (translation) or 6
        self.root_q = {0: 0, 3: 3, 6: 7}[root]  # free root configuration entries
        self.free = np.array(free, dtype=int)
        self.pres = np.array([i for i in range(pm.nv) if i not in free], dtype=int)
        offset = pm.nq - pm.nv  # 1 for a free flyer: joint rows shift by one in q
        joint_q = [i + offset for i in free if not (self.free_flyer and i < 6)]
        self.q_free = np.array(list(range(self.root_q)) + joint_q, dtype=int)
        self.nqf, self.nvf = self.q_free.size, self.free.size
        self._ff = np.ix_(self.free, self.free)
        # contiguous free rows (the leg's ankle, knee): slices instead of fancy indexing
        lo, hi = int(self.free[0]), int(self.free[-1]) + 1
        self._fs = slice(lo, hi) if hi - lo == self.nvf else self.free
        if not self.free_flyer and self._fs is not self.free:
            self._ff = (self._fs, self._fs)
        self._qs = self._fs if not self.free_flyer else self.q_free
        self._pivot = self._pivot_model()
        self._timed = tuple(f for f in self.forces if f.time_only)
        self._stateful = tuple(f for f in self.forces if not f.time_only)
        # (t, q, v, a, tau of the time-only forces, pivot shifts) of the latest call
        self._time = None

    def _pivot_model(self):
        """Fast path: planar base prescribed, every joint free, hinged at the base origin.

        The base's children then hang on a point (the base origin) with a prescribed
        translation: in the lab frame that is gravity g - a_origin on the chain with the
        base removed, whose first joints turn by the base pitch plus their own angle.
        So a_f = ABA(reduced model; g - a_origin) minus the base's angular acceleration
        on those first joints: one ``pin.aba`` on the chain (exact, no approximation).
        Returns (chain model, its data, child rows, lab gravity (3,), [a_x, a_z] the
        chain's gravity is shifted by now) or None when it does not apply.
        """
        pm = self.pm
        if (self.free_flyer or pm.njoints < 3 or pm.joints[1].nv != 3
                or self.pres.tolist() != [0, 1, 2]):
            return None
        for j in range(2, pm.njoints):
            placement = pm.jointPlacements[j]
            if pm.joints[j].shortname() != "JointModelRY" or not np.allclose(
                    placement.rotation[:, 1], [0.0, 1.0, 0.0]):
                return None
            if pm.parents[j] == 1 and np.any(placement.translation != 0.0):
                return None
        chain = pin.buildReducedModel(pm, [1], pin.neutral(pm))
        children = [pm.joints[j].idx_v - 3 for j in range(2, pm.njoints) if pm.parents[j] == 1]
        if len(children) == 1:  # the leg: one scalar index is cheapest
            children = children[0]
        elif children == list(range(children[0], children[-1] + 1)):
            children = slice(children[0], children[-1] + 1)
        gravity = np.array(pm.gravity.linear)
        # [a_x, a_z] of the base origin whose g - a the chain's gravity holds now
        return chain, chain.createData(), children, gravity, [0.0, 0.0]

    @property
    def nx(self) -> int:
        """State size."""
        return self.nqf + self.nvf

    def state_names(self) -> list[str]:
        """Names of the state entries (for messages and output columns)."""
        names = ["pelvis_tx", "pelvis_ty", "pelvis_tz", "pelvis_qx", "pelvis_qy",
                 "pelvis_qz", "pelvis_qw"][: self.root_q]
        v_names = self.velocity_names()
        joint_rows = [i for i in self.free if not (self.free_flyer and i < 6)]
        names += [v_names[i] for i in joint_rows]
        return names + [f"{v_names[i]}_speed" for i in self.free]

    def velocity_names(self) -> list[str]:
        """One name per velocity row."""
        pm = self.pm
        names = []
        for j in range(1, pm.njoints):
            nv, name = pm.joints[j].nv, pm.names[j]
            if nv == 1:
                names.append(name)
            elif self.free_flyer and j == 1:
                names += ["pelvis_vx", "pelvis_vy", "pelvis_vz", "pelvis_wx", "pelvis_wy",
                          "pelvis_wz"]
            else:  # the planar composite root
                names += list(getattr(self.model, "coordinate_names", ()))[:nv] or \
                    [f"{name}_{k}" for k in range(nv)]
        return names

    def state(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """State x from full q (nq,), v (nv,)."""
        return np.concatenate([np.asarray(q, dtype=float)[self.q_free],
                               np.asarray(v, dtype=float)[self.free]])

    def full_state(self, t: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q, v, a_prescribed) at t for state x (free entries of a are 0); new arrays."""
        q, v, a = self.motion(t)
        q[self._qs] = x[: self.nqf]
        if self.root_free:
            q[3:7] /= np.linalg.norm(q[3:7])
        v[self._fs] = x[self.nqf:]
        a[self._fs] = 0.0
        return q, v, a

    # -- forces -----------------------------------------------------------------------
    def _kinematics(self, q: np.ndarray, v: np.ndarray) -> None:
        if self.needs >= Kinematics.JACOBIANS:
            pm, data = self.pm, self.data
            pin.forwardKinematics(pm, data, q, v)
            pin.computeJointJacobians(pm, data, q)
            pin.updateFramePlacements(pm, data)

    def applied(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Sum of the applied generalised forces (nv,); updates the kinematics in data."""
        self._kinematics(q, v)
        tau = np.zeros(self.pm.nv)
        for force in self.forces:
            force.add(tau, t, q, v, self.data)
        return tau

    def applied_parts(self, t: float, q: np.ndarray, v: np.ndarray) -> dict[str, np.ndarray]:
        """Applied generalised forces (nv,) grouped by force name."""
        self._kinematics(q, v)
        parts: dict[str, np.ndarray] = {}
        for force in self.forces:
            force.add(parts.setdefault(force.name, np.zeros(self.pm.nv)), t, q, v, self.data)
        return parts

    # -- dynamics ---------------------------------------------------------------------
    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """Full symmetric mass matrix (nv, nv) at q (a new array)."""
        m = pin.crba(self.pm, self.data, q).copy()
        return np.triu(m) + np.triu(m, 1).T

    def accelerations(self, t: float, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                      tau: np.ndarray | None = None) -> np.ndarray:
        """Free accelerations a_f at t from the prescribed accelerations ``a``.

        The free entries of ``a`` MUST be 0 (as :meth:`full_state` returns them;
        :meth:`solve` takes any). ``tau``: the applied forces if already computed
        (else :meth:`applied`).
        """
        pm, data = self.pm, self.data
        if tau is None:
            tau = self.applied(t, q, v)
        if self.pres.size == 0:
            return pin.aba(pm, data, q, v, tau).copy()
        if self._pivot is not None:
            chain, chain_data, children, gravity, shifted_by = self._pivot
            ax, az, alpha = a[:3].tolist()
            if shifted_by[0] != ax or shifted_by[1] != az:  # Python floats: cheap test
                shifted_by[:] = ax, az
                chain.gravity.linear = gravity - (ax, 0.0, az)
            q_chain, v_chain = q[3:].copy(), v[3:].copy()
            q_chain[children] += q[2]
            v_chain[children] += v[2]
            a_free = pin.aba(chain, chain_data, q_chain, v_chain, tau[3:]).copy()
            a_free[children] -= alpha
            return a_free
        b = pin.rnea(pm, data, q, v, a)
        m = pin.crba(pm, data, q)
        fs = self._fs
        return _solve_small(m[self._ff], tau[fs] - b[fs])

    def reaction(self, t: float, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                 tau: np.ndarray | None = None) -> np.ndarray:
        """lambda_p (n_prescribed,): what the prescription supplies; ``a`` is complete."""
        if tau is None:
            tau = self.applied(t, q, v)
        return pin.rnea(self.pm, self.data, q, v, a)[self.pres] - tau[self.pres]

    def solve(self, t: float, q: np.ndarray, v: np.ndarray, a: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
        """(a_free, lambda_p) at t; ``a`` holds the prescribed accelerations (free ignored)."""
        tau = self.applied(t, q, v)
        full = np.array(a, dtype=float)
        full[self.free] = 0.0
        a_free = self.accelerations(t, q, v, full, tau)
        if self.pres.size == 0:
            return a_free, np.zeros(0)
        full[self.free] = a_free
        return a_free, self.reaction(t, q, v, full, tau)

    def fast_path(self, options: IntegratorOptions):
        """A faster equal evaluation of fixed-step and CVODES runs, or None (here: None).

        Configurations may return an object with ``trajectory(options) -> stepper`` and
        ``grid_solver(options) -> grid solver or None`` (see
        :func:`~predgait.dynamics.integrators.integrate`) and ``recover(t, x) -> (q, v, a,
        reaction)`` (the rows :func:`simulate_partitioned` would compute), e.g. the leg's
        :mod:`~predgait.dynamics.compiled_leg`.
        """
        return None

    def configuration_rate(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Rate of q_f (d q_f / dt) from the full q, v."""
        if not self.root_q:
            return v[self._fs]
        rate = np.empty(self.nqf)
        quat = q[3:7]
        rate[:3] = pin.Quaternion(quat[3], *quat[:3]).toRotationMatrix() @ v[:3]
        if self.root_free:
            w = v[3:6]
            x, y, z = quat[:3]  # quat[:3] x w written out: np.cross costs ~20 us here
            cross = np.array([y * w[2] - z * w[1], z * w[0] - x * w[2], x * w[1] - y * w[0]])
            rate[3:6] = 0.5 * (quat[3] * w + cross)
            rate[6] = -0.5 * quat[:3] @ w
        rate[self.root_q:] = v[self.free[self.root_v:]]
        return rate

    def _at_time(self, t: float) -> tuple:
        """(t, q, v, a, tau_t): the motion and time-only forces at t, computed once per t.

        q, v, a: the prescribed motion (free entries of a zero); tau_t: the sum of the
        time-only forces. The correctors of a modified-Euler step ask for the same t
        again and again.
        """
        q, v, a = (np.array(u, dtype=float) for u in self.motion(t))
        a[self._fs] = 0.0
        tau = np.zeros(self.pm.nv)
        for force in self._timed:
            force.add(tau, t, q, v, self.data)
        shifts = None
        if self._pivot is not None:  # what the base adds to the chain's q, v, a at t
            children = self._pivot[2]
            shifts = [np.zeros(self.nvf) for _ in range(3)]
            for shift, value in zip(shifts, (q[2], v[2], a[2]), strict=True):
                shift[children] = value
            shifts.append((float(a[0]), float(a[1])))
        self._time = (t, q, v, a, tau, shifts)
        return self._time

    def _evaluate(self, t: float, x: np.ndarray) -> tuple:
        """(q, v, a, tau, a_f) at (t, x); q, v, a are the time's buffers (not copies)."""
        at = self._time
        _, q, v, a, tau, shifts = at if at is not None and at[0] == t else self._at_time(t)
        nqf = self.nqf
        q[self._qs] = x[:nqf]  # the free entries of the time's buffers: set on every call
        if self.root_free:
            q[3:7] /= np.linalg.norm(q[3:7])
        v[self._fs] = x[nqf:]
        if self._stateful:  # the time's tau stays as it is for the next call
            tau = tau.copy()
            self._kinematics(q, v)
            for force in self._stateful:
                force.add(tau, t, q, v, self.data)
        if shifts is None:
            return q, v, a, tau, self.accelerations(t, q, v, a, tau)
        return q, v, a, tau, self._pivot_accelerations(x, tau, shifts)

    def _pivot_accelerations(self, x: np.ndarray, tau: np.ndarray, shifts) -> np.ndarray:
        """:meth:`accelerations`' pivot path from the state x and the time's shifts.

        The same equations with fewer NumPy calls (this runs ~10^4 times a simulated
        second): the base's pitch, rate and angular acceleration are added to or taken
        from the chain's first joints with arrays made once per time.
        """
        chain, chain_data, _, gravity, shifted_by = self._pivot
        q_shift, v_shift, a_shift, (ax, az) = shifts
        if shifted_by[0] != ax or shifted_by[1] != az:
            shifted_by[:] = ax, az
            chain.gravity.linear = gravity - (ax, 0.0, az)
        nqf = self.nqf
        a_free = pin.aba(chain, chain_data, x[:nqf] + q_shift, x[nqf:] + v_shift, tau[3:])
        return a_free - a_shift

    def __call__(self, t: float, x: np.ndarray) -> np.ndarray:
        """State derivative [q_f', a_f] at t."""
        q, v, _, _, a_free = self._evaluate(t, x)
        nqf = self.nqf
        out = np.empty(self.nx)
        out[:nqf] = x[nqf:] if not self.root_q else self.configuration_rate(q, v)
        out[nqf:] = a_free
        return out


def _recover(system: PartitionedSystem, times: np.ndarray, states: np.ndarray):
    """(q, v, a, reaction) at every output row (a row with NaN: its motion only)."""
    n, pm = len(times), system.pm
    q, v, a = np.zeros((n, pm.nq)), np.zeros((n, pm.nv)), np.zeros((n, pm.nv))
    reaction = np.zeros((n, system.pres.size))
    for k, (t, x) in enumerate(zip(times, states, strict=True)):
        if not np.all(np.isfinite(x)):
            q[k], v[k], a[k] = system.full_state(t, x)
            continue
        q[k], v[k], a[k], tau, a[k, system.free] = system._evaluate(t, x)
        if system.pres.size:
            reaction[k] = system.reaction(t, q[k], v[k], a[k], tau)
    return q, v, a, reaction


# ------------------------------------------------------------------------ result
@dataclass(frozen=True, eq=False)
class SimulationResult:
    """A forward simulation (any configuration of the engine).

    Attributes:
        t: (n,) s.
        q: (n, nq) all coordinates (prescribed ones included), m and rad.
        v: (n, nv) velocities.
        a: (n, nv) accelerations.
        reaction: (n, n_prescribed) lambda_p, what the prescription supplied.
        coordinate_names: names of the velocity rows (the coordinates of planar models).
        free: Names of the integrated velocity rows.
        status: COMPLETED, EVENT (a terminal event, see ``event``) or DIVERGED.
        event: Name of the event that stopped the run ("fall: ..." for falls), or None.
        time_to_fall: Time from the start to a fall event, s, or None.
        partial: True when the run diverged and this is what was computed until then.
        message: One line saying how the run ended.
        options: Integrator options used.
        n_rhs_evaluations: Right-hand-side calls.
        grf, cop: (n, 3) ground reaction on the leg's foot (N) and its COP (m), lab
            frame, when the leg's foot is prescribed; else None.
        extra: Further configuration-specific outputs.
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    reaction: np.ndarray
    coordinate_names: tuple[str, ...]
    free: tuple[str, ...]
    status: Status
    event: str | None
    time_to_fall: float | None
    partial: bool
    message: str
    options: IntegratorOptions
    n_rhs_evaluations: int
    grf: np.ndarray | None = None
    cop: np.ndarray | None = None
    extra: dict = field(default_factory=dict)


def simulate_partitioned(system: PartitionedSystem, t_span: tuple[float, float],
                         x0: np.ndarray, *, options: IntegratorOptions | None = None,
                         events: Sequence[Event] = (), progress: bool = False,
                         t_eval=None) -> SimulationResult:
    """Integrate ``system`` over ``t_span`` from x0 and recover the full motion.

    Events whose names start with "fall" are falls (``time_to_fall``).

    Raises:
        SimulationDiverged: NaN or blow-up; ``.partial`` is the SimulationResult so far
            (``partial=True``) and the message names the time and coordinate.
    """
    options = options or IntegratorOptions()
    error = None
    on_grid = options.method is Method.CVODES
    fast = system.fast_path(options) if options.method.fixed_step or on_grid else None
    try:
        run = integrate(system, t_span, x0, options=options, events=events,
                        progress=progress, state_names=system.state_names(), t_eval=t_eval,
                        stepper=fast.trajectory(options) if fast and not on_grid else None,
                        grid_solver=fast.grid_solver(options) if fast and on_grid else None)
    except SimulationDiverged as exc:
        run, error = exc.partial, exc
    if fast is not None:
        q, v, a, reaction = fast.recover(run.t, run.x)
    else:
        q, v, a, reaction = _recover(system, run.t, run.x)
    names = tuple(system.velocity_names())
    fall = (run.event_time - float(t_span[0])
            if (run.event_name or "").startswith("fall") else None)
    result = SimulationResult(
        t=run.t, q=q, v=v, a=a, reaction=reaction, coordinate_names=names,
        free=tuple(names[i] for i in system.free), status=run.status,
        event=run.event_name, time_to_fall=fall, partial=error is not None,
        message=run.message, options=replace(options, method=run.method),  # cvodes -> rk45
        n_rhs_evaluations=run.n_rhs_evaluations)
    if error is not None:
        raise SimulationDiverged(str(error), partial=result)
    return result
