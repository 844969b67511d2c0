"""Applied forces of the forward engine (:mod:`predgait.dynamics.partitioned`).

Each force adds its generalised force (nv,) to a buffer: ``force.add(tau, t, q, v,
data)``; calling it, ``force(t, q, v, data)``, returns that contribution alone. A force
says how much kinematics it reads from ``data`` (:class:`Kinematics`): the engine
updates ``data`` once per evaluation to the highest level any of its forces needs, so a
model whose forces need nothing (joint torques, passive elements, feedback) skips
forward kinematics and Jacobians altogether. ``name`` groups forces for the
acceleration contributions of :mod:`predgait.analysis.contributions`.

Forces: :class:`JointTorques` (sampled joint torques), :class:`PassiveTorques`
(passive elements on clinical angles, one sign table), :class:`JointFeedback` (the one PD
law), :class:`FrameLoad` (a world-frame wrench at one frame, e.g. the hip load),
:class:`MeasuredLoads` (world-frame loads at points, e.g. measured ground reactions)
and :class:`GroundContact` (point contacts with the floor).
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from predgait.dynamics.external import Load, generalized_load
from predgait.kinematics.clinical import ClinicalJoint, clinical_joint
from predgait.models.loading import RigidBodyModel

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


class Kinematics(enum.IntEnum):
    """What a force reads from ``pin.Data`` (the engine computes the highest level)."""

    NONE = 0        # nothing: the force uses q and v only (or computes what it needs)
    JACOBIANS = 1   # forwardKinematics(q, v), computeJointJacobians, updateFramePlacements


class Force:
    """Base of the applied forces: ``add`` is the primitive, calling returns one term."""

    name = "applied"
    needs = Kinematics.NONE
    time_only = False  # True: depends on t alone (the engine adds it once per time)

    def add(self, tau: np.ndarray, t: float, q: np.ndarray, v: np.ndarray,
            data: pin.Data) -> None:
        """Add the generalised force at (t, q, v) to ``tau`` (nv,) in place."""
        raise NotImplementedError

    def __call__(self, t, q, v, data) -> np.ndarray:
        """This force's generalised force (nv,) alone."""
        tau = np.zeros(v.size)
        self.add(tau, t, q, v, data)
        return tau


@dataclass(frozen=True, eq=False)
class CallableForce(Force):
    """Any ``function(t, q, v, data) -> (nv,)`` as a force (full kinematics in data)."""

    function: Callable
    name: str = "applied"
    needs = Kinematics.JACOBIANS

    def add(self, tau, t, q, v, data) -> None:
        """Add the function's generalised force."""
        tau += self.function(t, q, v, data)


def as_force(force) -> Force:
    """``force`` itself, or a plain callable wrapped in :class:`CallableForce`."""
    return force if isinstance(force, Force) else CallableForce(force)


@dataclass(frozen=True, eq=False)
class JointTorques(Force):
    """Sampled torques on chosen velocity rows: tau[rows] += history(t), N m (or N).

    Attributes:
        rows: Velocity rows. history: t -> (len(rows),). name: contribution group.
    """

    rows: np.ndarray | slice
    history: Callable[[float], np.ndarray]
    name: str = "active"
    time_only = True

    def add(self, tau, t, q, v, data) -> None:
        """Add the torques at t."""
        tau[self.rows] += self.history(t)


@dataclass(frozen=True, eq=False)
class PassiveTorques(Force):
    """Passive elements on clinical joint angles, through the one joint-sign table.

    For each joint, :func:`predgait.kinematics.clinical.clinical_joint` gives its
    coordinates and sign: clinical angle = sign * sum(q[rows]), and the element's clinical
    moment M acts as the generalised force sign * M on each of those rows (the moment
    conjugate to the clinical angle). The leg's hip is the thigh pitch (rows base_pitch,
    ankle, knee): a moment on the thigh, reacted by the prescribed foot.

    With ``offset`` (t -> (nv,)), that generalised force is subtracted: the elements then
    act on the deviation from a measured motion whose inverse-dynamics moments already
    contain them (thesis 3.3.3-3.3.4, the same elements in the indirect and forward
    problems); see :meth:`predgait.dynamics.drivers.LegDrivers.from_inverse`.

    Attributes:
        rows: joint name -> (velocity rows, its ClinicalJoint). joints: joint name ->
            PassiveJoint.
        offset: Optional t -> (nv,) generalised passive force at the measured motion.
    """

    rows: Mapping[str, tuple[tuple[int, ...], ClinicalJoint]]
    joints: Mapping[str, object]
    offset: Callable[[float], np.ndarray] | None = None
    name: str = "passive"

    @classmethod
    def on(cls, model: RigidBodyModel, joints: Mapping[str, object], *, offset=None
           ) -> PassiveTorques:
        """The elements ``joints`` (joint name -> PassiveJoint) on ``model``'s joints."""
        return cls(passive_rows(model, joints), dict(joints), offset)

    def add(self, tau, t, q, v, data) -> None:
        """Add the passive moments at (q, v) (minus the offset at t)."""
        for name, (rows, clinical) in self.rows.items():
            if len(rows) == 1:
                angle, rate = q[rows[0]], v[rows[0]]
            else:
                angle, rate = q[list(rows)].sum(), v[list(rows)].sum()
            moment = float(clinical.generalized_force(self.joints[name].moment, angle, rate))
            for row in rows:
                tau[row] += moment
        if self.offset is not None:
            tau -= self.offset(t)


def passive_rows(model: RigidBodyModel, joints
                 ) -> dict[str, tuple[tuple[int, ...], ClinicalJoint]]:
    """Joint name -> (velocity rows, ClinicalJoint) from the one joint-sign table."""
    out = {}
    for name in joints:
        joint = clinical_joint(model, name)
        out[name] = (tuple(model.coordinate_index(c) for c in joint.coordinates), joint)
    return out


def passive_generalized(model: RigidBodyModel, joints: Mapping[str, object], q, v
                        ) -> np.ndarray:
    """Generalised passive force (n, nv) along sampled q, v (n, nv), numpy or CasADi-free.

    The same table and signs as :class:`PassiveTorques` (used to build its ``offset``).
    """
    q, v = np.atleast_2d(q), np.atleast_2d(v)
    out = np.zeros(q.shape)
    for name, (rows, clinical) in passive_rows(model, joints).items():
        moment = np.asarray(clinical.generalized_force(
            joints[name].moment, q[:, list(rows)].sum(axis=1), v[:, list(rows)].sum(axis=1)),
            dtype=float)
        for row in rows:
            out[:, row] += moment
    return out


def joint_passive_torque(model: RigidBodyModel, joint: str, element) -> Callable:
    """(q, v) of a one-coordinate joint -> the element's model torque on that coordinate.

    The same table and signs as :class:`PassiveTorques`, for numpy or CasADi values
    (the fitting problems use it on symbols).
    """
    clinical = clinical_joint(model, joint)
    if len(clinical.coordinates) != 1:
        raise ValueError(f"joint '{joint}' spans several coordinates; use PassiveTorques.")
    return lambda q, v: clinical.generalized_force(element.moment, q, v)


@dataclass(frozen=True, eq=False)
class JointFeedback(Force):
    """PD feedback toward a reference motion on chosen 1-DOF joint velocity rows.

    tau[rows] += kp (q_ref - q) + kd (v_ref - v), with ``reference(t)`` -> (q_ref (nq,),
    v_ref (nv,), ...) full vectors (e.g. a :class:`MotionHistory` of the measured motion
    or :meth:`LegDrivers.reference`): a simple stand-in for the subject's control (thesis
    4.2 and chapter 5, future work). The one PD law of predgait.

    Attributes:
        rows: velocity rows of 1-DOF joints. kp: N m/rad (scalar or per row).
        kd: N m s/rad (scalar or per row; see :meth:`damped`).
        q_offset: nq - nv (1 with a free-flyer root: joint rows shift by one in q).
    """

    rows: np.ndarray
    reference: Callable[[float], tuple]
    kp: float | np.ndarray
    kd: float | np.ndarray
    q_offset: int = 0
    name: str = "feedback"

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

    def torque(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Feedback torques (len(rows),) at t."""
        ref = self.reference(t)
        rows_q = self.rows + self.q_offset
        return (self.kp * (ref[0][rows_q] - q[rows_q])
                + self.kd * (ref[1][self.rows] - v[self.rows]))

    def add(self, tau, t, q, v, data) -> None:
        """Add the feedback torques at t."""
        tau[self.rows] += self.torque(t, q, v)


@dataclass(frozen=True, eq=False)
class FrameLoad(Force):
    """A force and moment at the origin of one frame (e.g. the hip load).

    tau += J^T (f, m), J the frame Jacobian: LOCAL_WORLD_ALIGNED for lab-frame components,
    LOCAL with ``body_fixed`` (components on the frame's own axes, so the load turns with
    the segment: the thesis' body-based forces, 3.2.3 and 3.3.3). A load that is zero at
    all times is not added to a system at all (no Jacobian). No state: the wrench is
    read from ``force`` and ``moment`` at each call.

    Attributes:
        model: The model. frame: frame name. force, moment: t -> (3,) N, N m (lab frame,
        or the frame's axes with ``body_fixed``).
        body_fixed: Components on the frame's axes instead of the lab's.
    """

    model: RigidBodyModel
    frame: str
    force: Callable[[float], np.ndarray]
    moment: Callable[[float], np.ndarray]
    name: str = "load"
    body_fixed: bool = False

    def add(self, tau, t, q, v, data) -> None:
        """Add J^T w at t."""
        wrench = np.concatenate([self.force(t), self.moment(t)])
        jacobian = pin.computeFrameJacobian(self.model.pin_model, data, q,
                                            self.model.frame_id(self.frame),
                                            pin.LOCAL if self.body_fixed else LWA)
        tau += wrench.dot(jacobian)


@dataclass(frozen=True, eq=False)
class MeasuredLoads(Force):
    """World-frame loads at time t (e.g. measured ground reactions at their COP).

    ``loads(t, data)`` returns :class:`~predgait.dynamics.external.Load` objects; their
    generalised force is sum J^T w (:func:`~predgait.dynamics.external.generalized_load`).
    """

    model: RigidBodyModel
    loads: Callable[[float, pin.Data], Sequence[Load]]
    name: str = "load"
    needs = Kinematics.JACOBIANS

    def add(self, tau, t, q, v, data) -> None:
        """Add the loads' generalised force at t."""
        loads = self.loads(t, data)
        if loads:
            tau += generalized_load(self.model, data, loads)


@dataclass(frozen=True, eq=False)
class GroundContact(Force):
    """Point contacts of model frames with the ground plane z = ``ground_z``.

    Each frame gets the contact model's normal force along +Z from its penetration
    d = ground_z - z and rate -z_dot, and (if the model has friction) tangential forces
    along X and Y from its slip velocities (:mod:`predgait.dynamics.contact`), taken
    relative to the ground surface (a treadmill belt moves at ``belt_velocity`` along X).
    No state: :meth:`forces` and :meth:`forces_at` return the forces of a given state.

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
    _ids: tuple[int, ...] = field(init=False, repr=False)  # frame ids, fixed at creation
    name = "contact"
    needs = Kinematics.JACOBIANS

    def __post_init__(self):
        object.__setattr__(self, "_ids", tuple(self.model.frame_id(f) for f in self.frames))

    def forces(self, data: pin.Data) -> np.ndarray:
        """(n_frames, 3) lab-frame contact forces for the kinematics stored in ``data``.

        One call of the contact law for all frames and both slip axes (the laws
        broadcast over arrays); a frame more than 5 cm above the ground gets no force.
        """
        pm = self.model.pin_model
        positions = np.array([data.oMf[fid].translation[2] for fid in self._ids])
        velocities = np.array([pin.getFrameVelocity(pm, data, fid, LWA).linear
                               for fid in self._ids])
        near = positions <= self.ground_z + 0.05
        depth, rate = self.ground_z - positions, -velocities[:, 2]
        slip = velocities[:, :2].T - np.array([[self.belt_velocity], [0.0]])
        normal, tangential = self.contact.force(depth[None], rate[None], slip)
        out = np.zeros((len(self._ids), 3))
        out[:, 0] = np.where(near, tangential[0], 0.0)
        out[:, 2] = np.where(near, normal[0], 0.0)
        if not self.planar:
            out[:, 1] = np.where(near, tangential[1], 0.0)
        return out

    def forces_at(self, q: np.ndarray, v: np.ndarray, data: pin.Data | None = None
                  ) -> np.ndarray:
        """(n_frames, 3) lab-frame contact forces at the state (q, v) (kinematics computed)."""
        pm = self.model.pin_model
        data = pm.createData() if data is None else data
        pin.forwardKinematics(pm, data, q, v)
        pin.updateFramePlacements(pm, data)
        return self.forces(data)

    def add(self, tau, t, q, v, data) -> None:
        """Add the contact forces' generalised force at the kinematics in ``data``."""
        pm = self.model.pin_model
        for fid, force in zip(self._ids, self.forces(data), strict=True):
            if force.any():
                tau += pin.getFrameJacobian(pm, data, fid, LWA)[:3].T @ force
