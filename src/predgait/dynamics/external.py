"""External loads (ground reaction, hip load, rod end forces) as Pinocchio forces.

A load is a force and a moment given in the lab (world) frame, acting on a segment
at a point given in the world frame. Pinocchio's ``rnea``/``aba`` take external forces
per joint, expressed in the joint's local frame at its origin; :func:`joint_forces`
does that conversion, once, for every algorithm.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from predgait.models.loading import Model


@dataclass(frozen=True)
class Load:
    """A world-frame wrench on one segment.

    Attributes:
        segment: Name of the frame (segment or marker frame) the load acts on.
        force: (3,) force in the lab frame, N.
        point: (3,) point of application in the lab frame, m; ``None`` means the origin
            of the ``segment`` frame.
        moment: (3,) free moment in the lab frame, N m.
    """

    segment: str
    force: np.ndarray
    point: np.ndarray | None = None
    moment: np.ndarray | None = None


def joint_forces(model: Model, data: pin.Data, loads: Sequence[Load]) -> pin.StdVec_Force:
    """Per-joint local forces for Pinocchio; needs ``framesForwardKinematics`` done.

    Returns:
        A ``StdVec_Force`` of length ``njoints`` (zero where nothing acts).
    """
    pm = model.pin_model
    fext = pin.StdVec_Force()
    for _ in range(pm.njoints):
        fext.append(pin.Force.Zero())
    for load in loads:
        frame_id = model.frame_id(load.segment)
        joint = pm.frames[frame_id].parentJoint
        force = np.asarray(load.force, dtype=float)
        point = data.oMf[frame_id].translation if load.point is None else np.asarray(load.point)
        moment = np.zeros(3) if load.moment is None else np.asarray(load.moment, dtype=float)
        px, py, pz = point
        fx, fy, fz = force
        lever = np.array([py * fz - pz * fy, pz * fx - px * fz, px * fy - py * fx])
        world = pin.Force(force, moment + lever)  # moment about the world origin
        fext[joint] += data.oMi[joint].actInv(world)
    return fext


def generalized_load(model: Model, data: pin.Data, loads: Sequence[Load]) -> np.ndarray:
    """Generalised force (nv,) of the loads, sum of J^T w.

    Needs ``pin.computeJointJacobians`` and ``pin.updateFramePlacements`` at the current
    configuration. Equals ``rnea(q, v, a) - rnea(q, v, a, fext)``.
    """
    pm = model.pin_model
    tau = np.zeros(pm.nv)
    for load in loads:
        frame_id = model.frame_id(load.segment)
        joint = pm.frames[frame_id].parentJoint
        jac = pin.getJointJacobian(pm, data, joint, pin.ReferenceFrame.LOCAL)
        local = joint_forces(model, data, [load])[joint]
        tau += jac.T @ local.vector
    return tau
