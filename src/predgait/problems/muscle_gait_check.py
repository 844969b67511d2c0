"""Pinocchio's re-evaluation of a muscle-driven gait at every node, and foot slip.

Independent of the ADAM expressions the optimiser used for the skeleton: at each node
Pinocchio's RNEA gives M(q) a + h(q, v), the contact forces (the NLP's values) are applied
at their contact points through Pinocchio's frame Jacobians, and the muscle and lumbar
generalised forces are the NLP's. The residual

    RNEA(q, v, a) - tau_muscles - tau_springs - tau_lumbar - sum_c J_c^T F_c

must vanish (all rows: the pelvis is unactuated, every joint is driven by muscles only),
and ABA(q, v, tau) must return the NLP's accelerations. Slip: the horizontal speed of
each sphere's contact point (the material point of the foot at the contact, Pinocchio
kinematics) integrated over the nodes where that sphere carries more than
:data:`LOADED_FRACTION` of body weight.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

#: A sphere carrying more than this fraction of body weight counts as loaded.
LOADED_FRACTION = 0.1


def _point_jacobian(pm, data, frame: int, point: np.ndarray) -> np.ndarray:
    """(3, nv) Jacobian of a world point fixed to a frame's body (world-aligned)."""
    jac = pin.getFrameJacobian(pm, data, frame, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
    lever = point - data.oMf[frame].translation
    return jac[:3] - pin.skew(lever) @ jac[3:]


def node_check(plant, gait) -> dict:
    """Residuals and accelerations by Pinocchio at every node of ``gait`` (MuscleGait).

    Returns:
        ``residual`` (N+1, nq) N, N m; ``max_residual`` (largest |entry|);
        ``max_acceleration_error`` (largest |ABA - a|, rad/s^2 or m/s^2);
        ``contact_point_speed`` (N+1, n_spheres) m/s, horizontal speed of each contact
        point; ``nlp_residual_max`` (the NLP's own residual at the solution).
    """
    model = plant.model
    pm = model.pin_model
    data = pm.createData()
    frames = [model.frame_id(s.link) for s in plant.spheres]
    path = gait.path
    residual, accel_error, slip_speed = [], [], []
    for k in range(path.q.shape[0]):
        q, v, a = path.q[k], path.v[k], path.a[k]
        pin.forwardKinematics(pm, data, q, v)
        pin.computeJointJacobians(pm, data, q)
        pin.updateFramePlacements(pm, data)
        applied = gait.muscle_tau[k] + (plant.spring_forces(q, v) if plant.springs else 0.0)
        applied[plant.lumbar_row] += plant.lumbar_optimal_force * path.u[k]
        speeds = []
        for c, frame in enumerate(frames):
            jac = _point_jacobian(pm, data, frame, gait.points[k, c])
            applied += jac.T @ gait.grf[k, c]
            speeds.append(float((jac @ v)[0]))
        residual.append(pin.rnea(pm, data, q, v, a) - applied)
        accel_error.append(pin.aba(pm, data, q, v, applied) - a)
        slip_speed.append(speeds)
    residual = np.array(residual)
    return {"residual": residual, "max_residual": float(np.abs(residual).max()),
            "max_acceleration_error": float(np.abs(np.array(accel_error)).max()),
            "contact_point_speed": np.array(slip_speed),
            "nlp_residual_max": float(np.abs(gait.residual).max())}


def slip_per_stride(t: np.ndarray, normal: np.ndarray, speed: np.ndarray,
                    body_weight: float) -> np.ndarray:
    """(n_spheres,) m: slip of each contact point while loaded, over one stride.

    Args:
        t: (n,) s of a whole stride (first and last node the same instant of the cycle).
        normal: (n, n_spheres) N vertical forces.
        speed: (n, n_spheres) m/s horizontal contact point speeds.
        body_weight: N.
    """
    loaded = normal > LOADED_FRACTION * body_weight
    both = loaded[1:] & loaded[:-1]
    step = 0.5 * (np.abs(speed[1:]) + np.abs(speed[:-1])) * np.diff(t)[:, None]
    return (step * both).sum(axis=0)
