"""Quadratic smoothing terms of the whole-body tracking cost (issue 27).

Three least-squares terms sum_r w_r (A x - b)_r^2 on the decision vector x of
:func:`~predgait.problems.fullbody_tracking.tracking_nlp` (node-major
z_k = (dx_k, v_k, a_k, f_k / FORCE_UNIT)), each a mean over its nodes or intervals:

- joint torques against the measured inverse dynamics: the torque
  RNEA(q, v, a) - sum_c J_c^T f_c of the joints, linearised about the measured state
  (dx = 0, the measured v and a, the plate forces shared by the points in contact; exact
  in a and f, first order in dx and v), minus the measured joint moments;
- the change of the accelerations from node to node against the measured change (the
  trapezoidal rule's period-2h mode, a_k = +A, -A, +A..., changes no state and costs
  nothing else);
- the second difference of each contact point's force over the nodes (a point that
  lifts off unloads over several nodes instead of within one; a steady loading costs
  nothing).

Their Hessian 2 A^T W A is constant, so they add no symbolic work to the NLP. And the
bound that makes a heel hand its load to the toe over several nodes (:func:`fade_limits`).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from predgait.problems.fullbody_tracking_stage import (
    corrected_configuration,
    point_feet,
)

#: Finite-difference step of the torque's derivative in the configuration correction
#: (rad, m; central differences, error O(step^2) of torques of O(100) N m).
FD_STEP = 1e-6


def torque_linearisation(model, q_ref: np.ndarray, v: np.ndarray, a: np.ndarray,
                         forces: np.ndarray, points: tuple[str, ...]
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Joint torques at one node and their Jacobian in z = (dx, v, a, f).

    Args:
        model: the body (:class:`~predgait.models.loading3d.Model3D`).
        q_ref: (36,) configuration.
        v: (35,) velocity.
        a: (35,) acceleration.
        forces: (P, 3) lab forces on ``points``, N.
        points: the P contact frames.

    Returns:
        tau (29,) N m; jacobian (29, 105 + 3 P) in z (forces in N, not FORCE_UNIT).
    """
    pm, pdata = model.pin_model, model.pin_model.createData()
    count = len(points)
    jac = np.zeros((29, 105 + 3 * count))
    loaded = [(model.frame_id(p), f) for p, f in zip(points, forces, strict=True) if f.any()]
    frame = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED

    def joint_torque(dx, vel):
        # contact_inverse_dynamics on one node, its Pinocchio data reused (createData
        # took most of the 75 x 71 calls' time)
        q = corrected_configuration(q_ref, dx)
        tau = pin.rnea(pm, pdata, q, vel, a).copy()
        pin.computeJointJacobians(pm, pdata, q)
        pin.updateFramePlacements(pm, pdata)
        for fid, force in loaded:
            tau -= pin.getFrameJacobian(pm, pdata, fid, frame)[:3].T @ force
        return tau[6:]

    zero = np.zeros(35)
    tau = joint_torque(zero, v)
    for i in range(35):
        step = np.zeros(35)
        step[i] = FD_STEP
        jac[:, i] = (joint_torque(step, v) - joint_torque(-step, v)) / (2 * FD_STEP)
    q = corrected_configuration(q_ref, zero)
    pin.computeRNEADerivatives(pm, pdata, q, v, a)
    jac[:, 35:70] = pdata.dtau_dv[6:]
    mass = pin.crba(pm, pdata, q)
    mass = np.triu(mass) + np.triu(mass, 1).T
    jac[:, 70:105] = mass[6:]
    pin.computeJointJacobians(pm, pdata, q)
    pin.updateFramePlacements(pm, pdata)
    frame = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    for c, name in enumerate(points):
        point_jac = pin.getFrameJacobian(pm, pdata, model.frame_id(name), frame)[:3]
        jac[:, 105 + 3 * c: 108 + 3 * c] = -point_jac[:, 6:].T
    return tau, jac


def _difference_rows(n: int, nz: int, columns: np.ndarray, order: int
                     ) -> tuple[list, list, list]:
    """Triplets (rows, cols, values) of differences of z[columns] over the nodes.

    First (z_{k+1} - z_k) or second (z_{k+1} - 2 z_k + z_{k-1}) by ``order``.
    """
    stencil = {1: (-1.0, 1.0), 2: (1.0, -2.0, 1.0)}[order]
    rows, cols, vals = [], [], []
    m = columns.size
    for k in range(n - order):
        r = (k * m + np.arange(m)).tolist()
        for j, coef in enumerate(stencil):
            rows += r
            cols += ((k + j) * nz + columns).tolist()
            vals += [coef] * m
    return rows, cols, vals


def smoothing_terms(model, data, x0: np.ndarray, nz: int, force_unit: float,
                    torque_scale: float, acceleration_change_scale: float,
                    force_change_scale: float):
    """(A, b) as sparse ``casadi.DM`` and dense vector: the terms of the module docstring.

    Each row is scaled by sqrt(weight / count) (weight 1 / scale^2, count the nodes or
    intervals of its term), so the cost is sum((A x - b)^2). The torque rows are left out
    when ``data.tau`` is None.

    Args:
        model: the body.
        data: the problem's :class:`~predgait.problems.fullbody_tracking.TrackingData`
            (``tau`` the measured joint moments).
        x0: the reference decision vector (dx = 0, measured v and a, initial forces).
        nz: unknowns per node.
        force_unit: N per force unknown.
        torque_scale: N m.
        acceleration_change_scale: rad/s^2 (m/s^2 pelvis).
        force_change_scale: N, second difference of a point's force per node.
    """
    import casadi as cs

    n, count = data.nodes, len(data.points)
    rows, cols, vals, rhs = [], [], [], []
    start = 0
    z0 = x0.reshape(n, nz)
    if data.tau is not None:
        weight = 1.0 / (torque_scale * np.sqrt(n))
        for k in range(n):
            forces = force_unit * z0[k, 105:].reshape(count, 3)
            tau, jac = torque_linearisation(model, data.q[k], z0[k, 35:70], z0[k, 70:105],
                                            forces, data.points)
            jac[:, 105:] *= force_unit
            r, c = np.nonzero(jac)
            rows += (start + r).tolist()
            cols += (k * nz + c).tolist()
            vals += (weight * jac[r, c]).tolist()
            # tau0 + J (z - z0) - tau_meas = J z - (J z0 - tau0 + tau_meas)
            rhs.append(weight * (jac @ z0[k] - tau + data.tau[k]))
            start += 29
    for columns, order, scale, target in (
            (np.arange(70, 105), 1, acceleration_change_scale, np.diff(data.a, axis=0)),
            (np.arange(105, nz), 2, force_change_scale / force_unit, None)):
        if n <= order:
            continue
        weight = 1.0 / (scale * np.sqrt(n - order))
        r, c, v = _difference_rows(n, nz, columns, order)
        rows += (start + np.asarray(r)).tolist()
        cols += c
        vals += (weight * np.asarray(v)).tolist()
        size = (n - order) * columns.size
        rhs.append(np.zeros(size) if target is None else weight * target.ravel())
        start += size
    matrix = cs.DM.triplet(rows, cols, vals, start, n * nz)
    return matrix, np.concatenate(rhs)


def fade_limits(data, body_weight: float) -> np.ndarray:
    """(N, P) upper bound of each point's normal force, N (inf where none).

    A point in contact d <= ``fade_nodes`` nodes from a node where it is off while
    another point of its foot is on carries at most d / (fade_nodes + 1) x 1.5 body
    weights (a heel-off or a toe landing: the force moves between the foot's points
    over several nodes; a whole foot's landing and lift-off follow its plate). ``data``:
    a :class:`~predgait.problems.fullbody_tracking.TrackingData`; body_weight N.
    """
    m = data.fade_nodes
    feet = np.array(point_feet(data.points))
    limits = np.full(data.contact.shape, np.inf)
    if m <= 0:
        return limits
    for c, foot in enumerate(feet):
        others = data.contact[:, (feet == foot) & (np.arange(feet.size) != c)].any(axis=1)
        switches = np.flatnonzero(~data.contact[:, c] & others)
        for k in np.flatnonzero(data.contact[:, c]):
            if switches.size:
                d = np.abs(switches - k).min()
                if d <= m:
                    limits[k, c] = 1.5 * body_weight * d / (m + 1)
    return limits
