"""Planar inverse dynamics of the leg by Pinocchio RNEA, with the ground reaction given.

With the foot as the base, the leg's equations of motion read

    M(q) a + h(q, v) = S^T tau + J_G^T w_G + J_H^T w_H,

with the measured ground reaction w_G on the foot (at the COP) and the unknown hip load
w_H = (F_x, F_z, M_y) that the pelvis applies to the thigh at ``hip_center``. RNEA without
external forces gives the left side; the loads enter as J^T w with the world-frame joint
Jacobians and the wrenches taken about the world origin. The three base rows hold only
J_H^T w_H once J_G^T w_G is subtracted (the base has no actuator), which gives w_H; the
joint rows then give the ankle and knee torques. This is the thesis' bottom-up
Newton-Euler solution (3.3.3-3.3.5) done by Pinocchio; the tests check it against those
equations written out and against RNEA with Pinocchio force objects per frame.

Speed: one ``computeJointJacobians`` and one ``rnea`` call per frame; the loads, the hip
solve and the joint forces are numpy operations on all frames at once.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from predgait.dynamics.external import Load
from predgait.models.loading import Model, new_data


@dataclass(frozen=True)
class LegInverse:
    """Inverse-dynamics results per frame (lab frame, SI).

    Attributes:
        tau: (n, nq) generalised forces; joint rows are the ankle and knee torques
            (N m, model sign); base rows are the residual after the hip load (~0).
        hip_force: (n, 3) N, pelvis on thigh at ``hip_center``.
        hip_moment: (n, 3) N m, pelvis on thigh (Y only).
        joint_force: name -> (n, 3) N: the force the proximal segment exerts on the
            distal one at the ankle (shank on foot), knee (thigh on shank) and hip
            (pelvis on thigh).
    """

    tau: np.ndarray
    hip_force: np.ndarray
    hip_moment: np.ndarray
    joint_force: dict[str, np.ndarray]


@dataclass(frozen=True)
class LoadHistory:
    """A world-frame wrench on one segment at every frame (the batched :class:`Load`).

    Attributes:
        segment: Name of the frame (segment or marker frame) the load acts on.
        force: (n, 3) force in the lab frame, N.
        point: (n, 3) point of application in the lab frame, m (finite where the force is
            not zero).
        moment: (n, 3) free moment in the lab frame, N m, or ``None`` (zero).
    """

    segment: str
    force: np.ndarray
    point: np.ndarray
    moment: np.ndarray | None = None

    def wrench_about_origin(self) -> np.ndarray:
        """(n, 6) force and moment about the lab origin (Pinocchio order: linear, angular)."""
        force = np.asarray(self.force, dtype=float)
        moment = np.zeros_like(force) if self.moment is None else np.asarray(self.moment, float)
        loaded = np.any(force != 0.0, axis=1, keepdims=True)
        point = np.where(loaded, np.asarray(self.point, dtype=float), 0.0)  # NaN COP unloaded
        return np.hstack([force, moment + np.cross(point, force)])


def ground_loads(force: np.ndarray, cop: np.ndarray, free_moment: np.ndarray) -> list[Load]:
    """The ground reaction on the foot as a load (one frame)."""
    return [Load("foot", force, point=cop, moment=free_moment)]


def _wrenches_by_joint(model: Model, n: int, loads) -> dict[int, np.ndarray]:
    """Joint index -> (n, 6) sum of the loads on its body, about the lab origin."""
    pm = model.pin_model
    by_joint: dict[int, np.ndarray] = {}

    def add(segment: str, k, wrench: np.ndarray) -> None:
        joint = pm.frames[model.frame_id(segment)].parentJoint
        by_joint.setdefault(joint, np.zeros((n, 6)))[k] += wrench

    if all(isinstance(load, LoadHistory) for load in loads):
        for history in loads:
            add(history.segment, slice(None), history.wrench_about_origin())
        return by_joint
    if len(loads) != n:
        raise ValueError(f"loads has {len(loads)} frames; expected {n}.")
    for k, frame in enumerate(loads):
        for load in frame:
            if load.point is None:
                raise ValueError(f"the load on {load.segment!r} at frame {k} needs a point.")
            history = LoadHistory(load.segment, np.atleast_2d(load.force),
                                  np.atleast_2d(load.point),
                                  None if load.moment is None else np.atleast_2d(load.moment))
            add(load.segment, k, history.wrench_about_origin()[0])
    return by_joint


def leg_inverse_dynamics(model: Model, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                         loads: Sequence[LoadHistory] | Sequence[Sequence[Load]]
                         ) -> LegInverse:
    """Ankle and knee torques, hip load and joint forces for each frame.

    Args:
        model: The leg (foot as base; joints ``ankle`` and ``knee``).
        q: (n, nq) coordinates, m and rad.
        v: (n, nq) velocities.
        a: (n, nq) accelerations.
        loads: The external loads on the leg other than the hip (the ground reaction(s) on
            the foot): :class:`LoadHistory` objects (fast), or per frame a list of
            :class:`Load` with points given.
    """
    pm = model.pin_model
    data = new_data(pm)
    q, v, a = (np.asarray(x, dtype=float) for x in (q, v, a))
    n = len(q)
    ankle, knee = pm.getJointId("ankle"), pm.getJointId("knee")
    hip_frame = pm.frames[model.frame_id("hip_center")]
    thigh = hip_frame.parentJoint
    rnea = np.empty((n, pm.nv))
    jacobian = np.empty((n, 6, pm.nv))
    rotation = np.empty((n, 2, 3, 3))        # ankle and knee joint frames in the lab
    transmitted = np.empty((n, 2, 3))        # linear force through ankle and knee, local
    thigh_pose = np.empty((n, 4, 4))
    placements, local_forces = data.oMi, data.f   # views into `data`, updated by the calls
    for k in range(n):
        jacobian[k] = pin.computeJointJacobians(pm, data, q[k])   # and placements oMi
        rnea[k] = pin.rnea(pm, data, q[k], v[k], a[k])        # and local forces f
        rotation[k, 0] = placements[ankle].rotation
        rotation[k, 1] = placements[knee].rotation
        thigh_pose[k] = placements[thigh].homogeneous
        transmitted[k, 0] = local_forces[ankle].linear
        transmitted[k, 1] = local_forces[knee].linear

    # Columns of each joint's world Jacobian: the coordinates of the joints that support it.
    def columns(joint: int) -> np.ndarray:
        mask = np.zeros(pm.nv, dtype=bool)
        for j in pm.supports[joint]:
            mask[pm.idx_vs[j]:pm.idx_vs[j] + pm.nvs[j]] = True
        return mask

    subtree_wrench = {ankle: np.zeros((n, 6)), knee: np.zeros((n, 6))}
    rhs = rnea.copy()
    for joint, wrench in _wrenches_by_joint(model, n, loads).items():
        rhs -= np.einsum("kij,ki->kj", jacobian * columns(joint), wrench)
        for inside in subtree_wrench:
            if inside in pm.supports[joint]:
                subtree_wrench[inside] += wrench

    # Hip load (Fx, Fz, My) at hip_center as a wrench about the origin: E(p) @ w_H.
    p = np.einsum("kij,j->ki", thigh_pose[:, :3], np.append(hip_frame.placement.translation, 1))
    lift = np.zeros((n, 6, 3))
    lift[:, 0, 0] = lift[:, 2, 1] = lift[:, 4, 2] = 1.0
    lift[:, 3:, 0] = np.cross(p, [1.0, 0.0, 0.0])
    lift[:, 3:, 1] = np.cross(p, [0.0, 0.0, 1.0])
    hip_jacobian = np.einsum("kij,kia->kaj", jacobian * columns(thigh), lift)  # (n, 3, nv)
    base = slice(0, 3)
    hip = np.linalg.solve(np.swapaxes(hip_jacobian[:, :, base], 1, 2), rhs[:, base, None])[..., 0]
    tau = rhs - np.einsum("kaj,ka->kj", hip_jacobian, hip)
    hip_force = np.column_stack([hip[:, 0], np.zeros(n), hip[:, 1]])
    hip_world = np.einsum("kia,ka->ki", lift, hip)
    forces = {}
    for i, (name, joint) in enumerate((("ankle", ankle), ("knee", knee))):
        # RNEA's transmitted force (parent on child, world axes) minus the loads the child's
        # subtree receives from outside (the hip load, any load below): sign -> proximal on
        # distal.
        world = np.einsum("kij,kj->ki", rotation[:, i], transmitted[:, i])
        forces[name] = -(world - subtree_wrench[joint][:, :3] - hip_world[:, :3])
    forces["hip"] = hip_force
    hip_moment = np.column_stack([np.zeros(n), hip[:, 2], np.zeros(n)])
    return LegInverse(tau, hip_force.copy(), hip_moment, forces)
