"""Planar inverse dynamics of the leg by Pinocchio RNEA, with the ground reaction given.

With the foot as the base, the leg's equations of motion read

    M(q) qdd + h(q, qd) = S^T tau + J_G^T w_G + J_H^T w_H,

with the measured ground reaction w_G on the foot (at the COP) and the unknown hip load
w_H = (F_x, F_z, M_y) that the pelvis applies to the thigh at ``hip_center``. RNEA with
w_G as an external force returns the left side minus J_G^T w_G. Its three base rows hold
only J_H^T w_H (the base has no actuator), which gives w_H; the joint rows then give the
ankle and knee torques. This is the thesis' bottom-up Newton-Euler solution (3.3.3-3.3.5)
done by Pinocchio; the tests check it against those equations written out.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from predgait.dynamics.external import Load, joint_forces
from predgait.models.loading import Model

#: Rows of a 6-D LOCAL_WORLD_ALIGNED Jacobian in the sagittal plane: vx, vz, wy.
PLANAR_ROWS = [0, 2, 4]


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


def ground_loads(force: np.ndarray, cop: np.ndarray, free_moment: np.ndarray) -> list[Load]:
    """The ground reaction on the foot as a load (one frame)."""
    return [Load("foot", force, point=cop, moment=free_moment)]


def planar_jacobian(model: Model, data: pin.Data, frame: str) -> np.ndarray:
    """(3, nv) Jacobian of a frame's (vx, vz, wy) in the lab frame; kinematics must be done."""
    full = pin.getFrameJacobian(model.pin_model, data, model.frame_id(frame),
                                pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
    return full[PLANAR_ROWS, :]


def leg_inverse_dynamics(model: Model, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                         loads: Sequence[Sequence[Load]]) -> LegInverse:
    """Ankle and knee torques, hip load and joint forces for each frame.

    Args:
        model: The leg (foot as base).
        q: (n, nq) coordinates, m and rad.
        qd: (n, nq) velocities.
        qdd: (n, nq) accelerations.
        loads: Per frame, the external loads on the leg other than the hip (the ground
            reaction(s) on the foot).
    """
    pm = model.pin_model
    data = pm.createData()
    n = len(q)
    tau = np.zeros((n, pm.nv))
    hip = np.zeros((n, 3))
    forces = {name: np.zeros((n, 3)) for name in ("ankle", "knee", "hip")}
    ankle_joint, knee_joint = pm.getJointId("ankle"), pm.getJointId("knee")
    for k in range(n):
        pin.computeJointJacobians(pm, data, q[k])
        pin.updateFramePlacements(pm, data)
        rhs = pin.rnea(pm, data, q[k], qd[k], qdd[k], joint_forces(model, data, loads[k]))
        jac = planar_jacobian(model, data, "hip_center")
        wrench = np.linalg.solve(jac[:, :3].T, rhs[:3])
        hip[k] = wrench
        tau[k] = rhs - jac.T @ wrench
        hip_load = Load("hip_center", np.array([wrench[0], 0.0, wrench[1]]),
                        moment=np.array([0.0, wrench[2], 0.0]))
        pin.rnea(pm, data, q[k], qd[k], qdd[k],
                 joint_forces(model, data, [*loads[k], hip_load]))
        # data.f[j]: force from the parent body on body j (foot->shank, shank->thigh).
        forces["ankle"][k] = -data.oMi[ankle_joint].act(data.f[ankle_joint]).linear
        forces["knee"][k] = -data.oMi[knee_joint].act(data.f[knee_joint]).linear
    forces["hip"] = np.column_stack([hip[:, 0], np.zeros(n), hip[:, 1]])
    hip_moment = np.column_stack([np.zeros(n), hip[:, 2], np.zeros(n)])
    return LegInverse(tau, forces["hip"].copy(), hip_moment, forces)
