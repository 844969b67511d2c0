"""Forward dynamics of any predgait model with some coordinates prescribed.

The velocity coordinates split into free (f) and prescribed (p) ones. With Pinocchio's
mass matrix M (``pin.crba``), bias forces h (``pin.nonLinearEffects``) and the applied
generalised forces tau (joint torques, contact, measured loads, passive elements)::

    a_f      = M_ff^-1 (tau_f - h_f - M_fp a_p)          (free accelerations)
    lambda_p = M_pp a_p + M_pf a_f + h_p - tau_p          (what the prescription supplies)

as :mod:`predgait.dynamics.forward` does for the leg, but for any
:class:`~predgait.models.loading.RigidBodyModel`: the planar gait7 (PX-PZ-RY root) and
the 3D body (free-flyer pelvis). A free-flyer root is free or prescribed as a whole
(its 6 velocity rows), or only its translation is free (rows 0..2: position free,
orientation prescribed); when it is free its configuration is position (lab, m) and unit
quaternion (x, y, z, w), and its velocity is Pinocchio's (linear and angular velocity
in the pelvis frame), so ``d pos/dt = R v_lin`` and ``d quat/dt = 1/2 quat * (omega, 0)``.
The quaternion is renormalised whenever the state is read.

State: x = [q_f, v_f], q_f the configuration entries of the free joints (7 for a free
flyer), v_f their velocities. With nothing prescribed this is plain ABA.

Applied forces are callables ``force(t, q, v, data) -> (nv,)`` evaluated after
``pin.forwardKinematics(q, v)``, ``pin.computeJointJacobians`` and
``pin.updateFramePlacements`` on ``data`` (so they may read ``data.oMf``, frame
Jacobians and frame velocities): :class:`JointTorques`, :class:`MeasuredLoads` and
:class:`GroundContact` below, or anything with that signature.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from predgait.dynamics.drivers import SampledHistory
from predgait.dynamics.external import Load, generalized_load
from predgait.dynamics.integrators import Event, Integration, IntegratorOptions, integrate
from predgait.errors import InputError, SimulationDiverged
from predgait.models.loading import RigidBodyModel

GeneralizedForce = Callable[[float, np.ndarray, np.ndarray, pin.Data], np.ndarray]
LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


# ---------------------------------------------------------------- prescribed motion
class MotionHistory:
    """Sampled motion of every coordinate as splines: t -> (q (nq,), v (nv,), a (nv,)).

    Joint angles and the root position are cubic splines of the samples; a free-flyer
    orientation is splined as the rotation vector log3(R_0^T R) relative to the first
    sample and mapped back with exp3 (fine for the small pelvis rotations of walking).
    v and a are splines of the given velocity and acceleration samples (e.g. those
    :func:`predgait.dynamics.inverse3d.velocities` fed to inverse dynamics), so a
    prescribed coordinate moves exactly as inverse dynamics assumed at the samples.

    Args:
        model: The model (decides whether rows 3:7 are a quaternion).
        time: (n,) s. q: (n, nq). v, a: (n, nv).
    """

    def __init__(self, model: RigidBodyModel, time, q, v, a):
        pm = model.pin_model
        q, v, a = (np.asarray(x, dtype=float) for x in (q, v, a))
        if q.shape[1:] != (pm.nq,) or v.shape[1:] != (pm.nv,) or a.shape[1:] != (pm.nv,):
            raise InputError(f"motion history: expected q (n, {pm.nq}), v and a (n, {pm.nv}); "
                             f"got {q.shape}, {v.shape}, {a.shape}.")
        self.free_flyer = pm.nq != pm.nv
        self.time_range = (float(time[0]), float(time[-1]))
        if self.free_flyer:
            self._r0 = pin.Quaternion(q[0, 6], *q[0, 3:6]).normalized().toRotationMatrix()
            logs = np.array([pin.log3(self._r0.T @ pin.Quaternion(r[6], *r[3:6])
                                      .normalized().toRotationMatrix()) for r in q])
            samples = np.hstack([q[:, :3], logs, q[:, 7:]])
        else:
            samples = q
        self._q = SampledHistory(time, samples, name="prescribed coordinates")
        self._v = SampledHistory(time, v, name="prescribed velocities")
        self._a = SampledHistory(time, a, name="prescribed accelerations")

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q, v, a) at t (s), new arrays."""
        row = self._q(t)
        if self.free_flyer:
            quat = pin.Quaternion(self._r0 @ pin.exp3(row[3:6])).coeffs()
            q = np.concatenate([row[:3], quat, row[6:]])
        else:
            q = row.copy()
        return q, self._v(t).copy(), self._a(t).copy()


# ------------------------------------------------------------------ applied forces
@dataclass(frozen=True)
class JointTorques:
    """Sampled torques on chosen velocity rows: tau[rows] = history(t) (N m or N)."""

    rows: np.ndarray
    history: Callable[[float], np.ndarray]

    def __call__(self, t, q, v, data) -> np.ndarray:
        """Generalised force (nv,) at t."""
        tau = np.zeros(v.size)
        tau[self.rows] = self.history(t)
        return tau


@dataclass(frozen=True)
class PassiveTorques:
    """Passive joint elements on 1-DOF rows: tau[row] = joint.moment(q, v), N m.

    ``joint`` is a :class:`~predgait.dynamics.passive.PassiveJoint` (clinical law); use it
    on rows whose coordinate has the clinical sign (e.g. gait7's knee flexion). Rows index
    q and v alike (models without a free-flyer root).
    """

    rows: tuple[int, ...]
    joint: object

    def __call__(self, t, q, v, data) -> np.ndarray:
        """Generalised force (nv,), N m on the rows."""
        tau = np.zeros(v.size)
        for row in self.rows:
            tau[row] = float(self.joint.moment(q[row], v[row]))
        return tau


@dataclass(frozen=True)
class JointFeedback:
    """PD feedback toward a reference motion on chosen (1-DOF joint) velocity rows.

    tau[rows] = kp (q_ref - q) + kd (v_ref - v), the reference from ``reference(t)`` ->
    (q, v, a) full vectors (e.g. a :class:`MotionHistory` of the measured motion): a simple
    stand-in for the subject's control (thesis chapter 5, future work).

    Attributes:
        rows: velocity rows of 1-DOF joints. kp: N m/rad (scalar or per row).
        kd: N m s/rad (scalar or per row; see :meth:`damped`).
        q_offset: nq - nv (1 with a free-flyer root: joint rows shift by one in q).
    """

    rows: np.ndarray
    reference: Callable[[float], tuple[np.ndarray, np.ndarray, np.ndarray]]
    kp: float | np.ndarray
    kd: float | np.ndarray
    q_offset: int = 0

    @classmethod
    def damped(cls, model: RigidBodyModel, rows, reference, kp: float, ratio: float,
               q: np.ndarray) -> JointFeedback:
        """Stiffness ``kp`` on every row, damping 2 ratio sqrt(kp M_ii) at configuration q.

        Each joint gets the damping ratio ``ratio`` for its own inertia M_ii (pin.crba):
        one kd for all would overdamp a foot (M_ii ~ 1e-3 kg m^2) into a time constant
        far below the integration step, and underdamp the trunk.
        """
        rows = np.asarray(rows, dtype=int)
        inertia = np.diag(pin.crba(model.pin_model, model.pin_model.createData(), q))[rows]
        return cls(rows, reference, kp, 2.0 * ratio * np.sqrt(kp * inertia),
                   q_offset=model.pin_model.nq - model.pin_model.nv)

    def __call__(self, t, q, v, data) -> np.ndarray:
        """Generalised force (nv,) of the feedback at t."""
        q_ref, v_ref, _ = self.reference(t)
        tau = np.zeros(v.size)
        rows_q = self.rows + self.q_offset
        tau[self.rows] = (self.kp * (q_ref[rows_q] - q[rows_q])
                          + self.kd * (v_ref[self.rows] - v[self.rows]))
        return tau


@dataclass(frozen=True)
class MeasuredLoads:
    """World-frame loads at time t (e.g. measured ground reactions at their COP).

    ``loads(t, data)`` returns :class:`~predgait.dynamics.external.Load` objects; their
    generalised force is sum J^T w (:func:`~predgait.dynamics.external.generalized_load`).
    """

    model: RigidBodyModel
    loads: Callable[[float, pin.Data], Sequence[Load]]

    def __call__(self, t, q, v, data) -> np.ndarray:
        """Generalised force (nv,) of the loads at t."""
        loads = self.loads(t, data)
        return generalized_load(self.model, data, loads) if loads else np.zeros(v.size)


@dataclass
class GroundContact:
    """Point contacts of model frames with the ground plane z = ``ground_z``.

    Each frame gets the contact model's normal force along +Z from its penetration
    d = ground_z - z and rate -z_dot, and (if the model has friction) tangential forces
    along X and Y from its slip velocities (:mod:`predgait.dynamics.contact`), taken
    relative to the ground surface (a treadmill belt moves at ``belt_velocity`` along X).
    ``last_forces`` holds the (n_frames, 3) lab-frame forces of the latest call.

    Attributes:
        model: The model. frames: contact frame names. contact: a contact model with
        ``force(penetration, rate, slip) -> (normal, tangential)``. ground_z: m.
        planar: only X slip (planar models). belt_velocity: m/s along X of the ground
        surface (0: fixed floor).
    """

    model: RigidBodyModel
    frames: Sequence[str]
    contact: object
    ground_z: float = 0.0
    planar: bool = False
    belt_velocity: float = 0.0
    last_forces: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        self._ids = [self.model.frame_id(f) for f in self.frames]
        self.last_forces = np.zeros((len(self._ids), 3))

    def forces(self, data: pin.Data) -> np.ndarray:
        """(n_frames, 3) lab-frame contact forces for the kinematics stored in ``data``."""
        pm = self.model.pin_model
        out = np.zeros((len(self._ids), 3))
        for i, fid in enumerate(self._ids):
            z = data.oMf[fid].translation[2]
            if z > self.ground_z + 0.05:  # far above ground: no force (cheap exit)
                continue
            vel = pin.getFrameVelocity(pm, data, fid, LWA).linear
            depth, rate = self.ground_z - z, -vel[2]
            normal, tx = self.contact.force(depth, rate, vel[0] - self.belt_velocity)
            out[i, 0], out[i, 2] = float(tx), float(normal)
            if not self.planar:
                out[i, 1] = float(self.contact.force(depth, rate, vel[1])[1])
        return out

    def __call__(self, t, q, v, data) -> np.ndarray:
        """Generalised force (nv,) of the contact forces (stored in ``last_forces``)."""
        pm = self.model.pin_model
        self.last_forces = self.forces(data)
        tau = np.zeros(v.size)
        for fid, force in zip(self._ids, self.last_forces, strict=True):
            if force.any():
                tau += pin.getFrameJacobian(pm, data, fid, LWA)[:3].T @ force
        return tau


# ------------------------------------------------------------------------ system
class PartitionedSystem:
    """x' = f(t, x) for a model with the coordinates outside ``free`` prescribed.

    Args:
        model: Any predgait model (planar root or free flyer).
        free: Velocity indices integrated (for a free-flyer root: all of 0..5, only the
            translation 0..2, or none).
        motion: t -> (q, v, a) full vectors; the prescribed entries are used (e.g.
            :class:`MotionHistory`). The free entries are ignored.
        forces: Applied generalised forces (see module docstring).
    """

    def __init__(self, model: RigidBodyModel, free: Sequence[int],
                 motion: Callable[[float], tuple[np.ndarray, np.ndarray, np.ndarray]],
                 forces: Sequence[GeneralizedForce] = ()):
        pm = model.pin_model
        self.model, self.pm, self.data = model, pm, pm.createData()
        self.motion, self.forces = motion, tuple(forces)
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
        self._lower = np.tril_indices(pm.nv, -1)
        self._ff, self._fp = np.ix_(self.free, self.free), np.ix_(self.free, self.pres)
        self._pp, self._pf = np.ix_(self.pres, self.pres), np.ix_(self.pres, self.free)

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
        """(q, v, a_prescribed) at t for state x (free entries of a are 0)."""
        q, v, a = self.motion(t)
        q[self.q_free] = x[: self.nqf]
        if self.root_free:
            q[3:7] /= np.linalg.norm(q[3:7])
        v[self.free] = x[self.nqf:]
        a[self.free] = 0.0
        return q, v, a

    def applied(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Sum of the applied generalised forces (nv,); updates the kinematics in data."""
        pm, data = self.pm, self.data
        pin.forwardKinematics(pm, data, q, v)
        pin.computeJointJacobians(pm, data, q)
        pin.updateFramePlacements(pm, data)
        tau = np.zeros(pm.nv)
        for force in self.forces:
            tau += force(t, q, v, data)
        return tau

    def solve(self, t: float, q: np.ndarray, v: np.ndarray, a: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
        """(a_free, lambda_p) at t; ``a`` holds the prescribed accelerations."""
        pm, data = self.pm, self.data
        tau = self.applied(t, q, v)
        h = pin.nonLinearEffects(pm, data, q, v)
        if self.pres.size == 0:
            return pin.aba(pm, data, q, v, tau), np.zeros(0)
        M = pin.crba(pm, data, q)
        M[self._lower] = M.T[self._lower]
        f, p = self.free, self.pres
        a_free = np.linalg.solve(M[self._ff], tau[f] - h[f] - M[self._fp] @ a[p])
        lam = M[self._pp] @ a[p] + M[self._pf] @ a_free + h[p] - tau[p]
        return a_free, lam

    def configuration_rate(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Rate of q_f (d q_f / dt) from the full q, v."""
        rate = np.empty(self.nqf)
        if self.root_q:
            quat = q[3:7]
            rate[:3] = pin.Quaternion(quat[3], *quat[:3]).toRotationMatrix() @ v[:3]
        if self.root_free:
            w = v[3:6]
            rate[3:6] = 0.5 * (quat[3] * w + np.cross(quat[:3], w))
            rate[6] = -0.5 * quat[:3] @ w
        rate[self.root_q:] = v[self.free[self.root_v:]]
        return rate

    def __call__(self, t: float, x: np.ndarray) -> np.ndarray:
        """State derivative [q_f', a_f] at t."""
        q, v, a = self.full_state(t, x)
        a_free = self.solve(t, q, v, a)[0]
        return np.concatenate([self.configuration_rate(q, v), a_free])


@dataclass(frozen=True, eq=False)
class PartitionedRun:
    """A simulation of a :class:`PartitionedSystem`.

    Attributes:
        t: (n,) s. q: (n, nq), v: (n, nv), a: (n, nv) full vectors (prescribed included).
        reaction: (n, n_prescribed) lambda_p, what the prescription supplied.
        integration: The raw :class:`~predgait.dynamics.integrators.Integration`.
        partial: True when the run diverged (this is what was computed until then).
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    reaction: np.ndarray
    integration: Integration
    partial: bool


def simulate_partitioned(system: PartitionedSystem, t_span: tuple[float, float],
                         x0: np.ndarray, *, options: IntegratorOptions,
                         events: Sequence[Event] = (), progress: bool = False,
                         t_eval=None) -> PartitionedRun:
    """Integrate ``system`` over ``t_span`` from x0 and recover the full motion.

    Raises:
        SimulationDiverged: NaN or blow-up; ``.partial`` is the PartitionedRun so far.
    """
    error = None
    try:
        run = integrate(system, t_span, x0, options=options, events=events,
                        progress=progress, state_names=system.state_names(), t_eval=t_eval)
    except SimulationDiverged as exc:
        run, error = exc.partial, exc
    n, pm = len(run.t), system.pm
    q, v, a = np.zeros((n, pm.nq)), np.zeros((n, pm.nv)), np.zeros((n, pm.nv))
    reaction = np.zeros((n, system.pres.size))
    for k, (t, x) in enumerate(zip(run.t, run.x, strict=True)):
        q[k], v[k], a[k] = system.full_state(t, x)
        if np.all(np.isfinite(x)):
            a[k, system.free], reaction[k] = system.solve(t, q[k], v[k], a[k])
    result = PartitionedRun(run.t, q, v, a, reaction, run, error is not None)
    if error is not None:
        raise SimulationDiverged(str(error), partial=result)
    return result
