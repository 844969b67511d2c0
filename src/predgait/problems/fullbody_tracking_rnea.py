"""Floating-base rows of the inverse dynamics by one recursive Newton-Euler pass (CasADi).

The whole-body tracking problem (:mod:`predgait.problems.fullbody_tracking`) constrains
only the six pelvis rows of RNEA(q, v, a) - sum_c J_c^T f_c. Written as M(q)_{0:6,:} a +
h(q, v)_{0:6} with ADAM's symbolic 35x35 mass matrix, one node's Hessian of the
Lagrangian took 561k CasADi instructions (163 ms a call, issue 27 item 5). The same rows
come from one RNEA pass (Featherstone 2008, Rigid Body Dynamics Algorithms, sec. 5.3,
table 5.1): a forward pass of the body velocities and accelerations, each body's
momentum rate I_i a_i + v_i x* I_i v_i, and a backward pass summing them into the root;
the root's accumulated wrench in its own frame is the six base rows (its motion subspace
is the identity). The same forward pass also gives the contact points' lab positions and
velocities, so one node needs no Jacobian.

Conventions are Pinocchio's (Carpentier et al. 2019, IEEE/SICE SII, "The Pinocchio C++
library"): spatial motion (linear, angular) and force (linear, angular) in each joint's
local frame, the free flyer's velocity the pelvis twist in the pelvis frame, gravity
entered as the root's acceleration -g. Units: m, s, kg, N, N m. The model's joints must
be one free flyer at the root and revolute joints about a local axis (Pinocchio's RX,
RY, RZ), as :mod:`predgait.models.fullbody` builds them.

Not a hand derivation of this body's equations (ARCHITECTURE.md): Featherstone's generic
algorithm walks Pinocchio's own tree, placements and inertias, and
``tests/test_fullbody_tracking_rnea.py`` checks it equal to ``pinocchio.rnea`` and
Pinocchio's frame kinematics at seeded random states (ADAM offers only the reduced RNEA,
without accelerations).
"""

from __future__ import annotations

import casadi as cs
import numpy as np
import pinocchio as pin

from predgait.errors import InputError

_AXES = {"JointModelRX": 0, "JointModelRY": 1, "JointModelRZ": 2}


def _axis_rotation(axis: int, angle) -> cs.SX:
    """3x3 rotation by ``angle`` (rad, SX) about the local axis 0, 1 or 2."""
    c, s = cs.cos(angle), cs.sin(angle)
    if axis == 0:
        return cs.vertcat(cs.horzcat(1, 0, 0), cs.horzcat(0, c, -s), cs.horzcat(0, s, c))
    if axis == 1:
        return cs.vertcat(cs.horzcat(c, 0, s), cs.horzcat(0, 1, 0), cs.horzcat(-s, 0, c))
    return cs.vertcat(cs.horzcat(c, -s, 0), cs.horzcat(s, c, 0), cs.horzcat(0, 0, 1))


def _unit(axis: int) -> np.ndarray:
    e = np.zeros(3)
    e[axis] = 1.0
    return e


def base_rows(pm: pin.Model, rot, pos, s, v, a, frames: tuple[str, ...]):
    """Pelvis rows of RNEA and the lab positions and velocities of ``frames`` (SX).

    Args:
        pm: Pinocchio model (root free flyer, then revolute joints RX / RY / RZ).
        rot: (3, 3) lab-from-pelvis rotation.
        pos: (3,) pelvis origin in the lab, m.
        s: (nv - 6,) joint angles in Pinocchio's order, rad.
        v: (nv,) velocity: pelvis twist in the pelvis frame (m/s, rad/s), joint rates.
        a: (nv,) its time derivative (m/s^2, rad/s^2).
        frames: names of frames fixed on bodies of ``pm``.

    Returns:
        (wrench, positions, velocities): wrench (6,) the base rows of RNEA(q, v, a)
        (force N, moment N m, pelvis frame, about its origin, gravity included);
        positions and velocities (3,) each per frame, lab (m, m/s).

    Raises:
        InputError: a joint other than a root free flyer and revolute RX / RY / RZ.
    """
    if pm.joints[1].shortname() != "JointModelFreeFlyer" or not pm.jointPlacements[1].isIdentity():
        raise InputError("the RNEA base rows need the model's first joint to be a free "
                         "flyer at the world origin.")
    gravity = np.asarray(pm.gravity.linear)
    # Joint 1 (root): its motion subspace is the identity in its own frame.
    lin = {1: v[:3]}
    ang = {1: v[3:6]}
    acc_lin = {1: a[:3] - rot.T @ gravity}
    acc_ang = {1: a[3:6]}
    world_rot, world_pos = {1: rot}, {1: pos}
    parent_of, local = {}, {}
    for j in range(2, pm.njoints):
        kind = pm.joints[j].shortname()
        if kind not in _AXES:
            raise InputError(f"joint {pm.names[j]!r} is a {kind}: the RNEA base rows take "
                             "revolute joints about a local axis (RX, RY, RZ) only.")
        axis, iv = _AXES[kind], pm.joints[j].idx_v
        parent = pm.parents[j]
        placement = pm.jointPlacements[j]
        r = cs.DM(placement.rotation) @ _axis_rotation(axis, s[iv - 6])
        p = cs.DM(placement.translation)
        e = _unit(axis)
        qd, qdd = v[iv], a[iv]
        # Parent motion to this joint's frame: w' = R^T w, u' = R^T (u + w x p).
        w_p = ang[parent]
        ang[j] = r.T @ w_p + e * qd
        lin[j] = r.T @ (lin[parent] + cs.cross(w_p, p))
        alpha_p = acc_ang[parent]
        # a_j = X a_parent + S qdd + v_j x (S qd), with S = (0, e).
        acc_ang[j] = r.T @ alpha_p + e * qdd + cs.cross(ang[j], e * qd)
        acc_lin[j] = r.T @ (acc_lin[parent] + cs.cross(alpha_p, p)) + cs.cross(lin[j], e * qd)
        world_rot[j] = world_rot[parent] @ r
        world_pos[j] = world_pos[parent] + world_rot[parent] @ p
        parent_of[j], local[j] = parent, (r, p)
    # Each body's momentum rate, then the backward pass into the root.
    force = {j: cs.SX.zeros(3) for j in range(1, pm.njoints)}
    moment = {j: cs.SX.zeros(3) for j in range(1, pm.njoints)}
    for j in range(1, pm.njoints):
        inertia = pm.inertias[j]
        if inertia.mass == 0.0 and not np.any(inertia.inertia):
            continue
        force[j], moment[j] = _momentum_rate(inertia, lin[j], ang[j], acc_lin[j], acc_ang[j])
    for j in range(pm.njoints - 1, 1, -1):
        r, p = local[j]
        f_parent = r @ force[j]
        force[parent_of[j]] = force[parent_of[j]] + f_parent
        moment[parent_of[j]] = moment[parent_of[j]] + r @ moment[j] + cs.cross(p, f_parent)
    positions, velocities = [], []
    for name in frames:
        frame = pm.frames[pm.getFrameId(name)]
        j, offset = frame.parentJoint, frame.placement.translation
        positions.append(world_pos[j] + world_rot[j] @ offset)
        velocities.append(world_rot[j] @ (lin[j] + cs.cross(ang[j], offset)))
    return cs.vertcat(force[1], moment[1]), positions, velocities


def _momentum_rate(inertia: pin.Inertia, u, w, du, dw):
    """I a + v x* I v of one body: force and moment about its joint origin (local frame).

    Momentum of twist (u, w) about the origin: l = m (u + w x c), k = I_c w + c x l
    (c the centre of mass, I_c the rotational inertia about it); v x* (l, k) =
    (w x l, w x k + u x l).
    """
    mass, com = inertia.mass, cs.DM(inertia.lever)
    rotational = cs.DM(inertia.inertia)

    def momentum(lin, ang):
        linear = mass * (lin + cs.cross(ang, com))
        return linear, rotational @ ang + cs.cross(com, linear)

    l_a, k_a = momentum(du, dw)
    l_v, k_v = momentum(u, w)
    return l_a + cs.cross(w, l_v), k_a + cs.cross(w, k_v) + cs.cross(u, l_v)
