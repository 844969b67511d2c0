"""Symbolic stage of the whole-body tracking problem: one node and one interval (SX).

The functions :mod:`predgait.problems.fullbody_tracking` maps over its nodes and
intervals, with their derivatives (constraint Jacobian, cost gradient, Hessian of the
Lagrangian), so that the NLP's symbolic work does not grow with the number of nodes.
Conventions, unknowns and the cost: that module's docstring. Also their numeric
counterparts (Pinocchio): the corrected configuration and the contact inverse dynamics.
The node's pelvis rows and contact-point kinematics come from one recursive Newton-Euler
pass (:mod:`~predgait.problems.fullbody_tracking_rnea`), not from ADAM's mass matrix:
the node's Hessian of the Lagrangian 149k CasADi instructions instead of 561k.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import casadi as cs
import numpy as np
import pinocchio as pin

from predgait.dynamics.contact import adams_step
from predgait.errors import InputError
from predgait.models.fullbody import CONTACTS
from predgait.models.loading3d import Model3D
from predgait.problems.fullbody_tracking_rnea import base_rows

#: Default contact points (the sole's centre line), in the order of the force arrays:
#: right heel, right toe, left heel, left toe. A problem may give others
#: (e.g. :data:`~predgait.models.fullbody.SOLE_EDGES`); each belongs to the foot of its
#: name's side suffix (:func:`point_feet`).
POINTS = ("heel_contact_r", "toe_contact_r", "heel_contact_l", "toe_contact_l")
assert set(POINTS) == set(CONTACTS)


def point_feet(points: tuple[str, ...]) -> tuple[int, ...]:
    """Foot of each point: 0 right (name ends ``_r``), 1 left (``_l``).

    Raises:
        InputError: a name ends in neither.
    """
    feet = []
    for name in points:
        if not name.endswith(("_r", "_l")):
            raise InputError(f"contact frame {name!r}: its name must end in _r or _l (the "
                             "foot it belongs to), e.g. heel_contact_r.")
        feet.append(0 if name.endswith("_r") else 1)
    return tuple(feet)


def _skew(w):
    return cs.vertcat(cs.horzcat(0, -w[2], w[1]), cs.horzcat(w[2], 0, -w[0]),
                      cs.horzcat(-w[1], w[0], 0))


def cayley(c):
    """Rotation matrix of the Cayley vector c (3,): I + 2/(1 + c.c) ([c]x + [c]x^2)."""
    k = _skew(c)
    return cs.DM.eye(3) + 2.0 / (1.0 + cs.dot(c, c)) * (k + k @ k)


@functools.lru_cache(maxsize=4)
def node_function(model: Model3D, points: tuple[str, ...] = POINTS) -> cs.Function:
    """``node(q_ref, dx, v, a, f) -> (eom, points, rot, pos, point_velocities)``.

    One RNEA pass (:func:`~predgait.problems.fullbody_tracking_rnea.base_rows`).
    q_ref (36,), dx (35,) correction, v, a (35,), f (3 P,) forces on ``points`` (P);
    eom (6,) the floating-base rows (N, N m, pelvis frame); points (3 P,) lab positions
    of the contact points; rot (9,) R column-major; pos (3,) pelvis position;
    point_velocities (3 P,) lab velocities of the contact points.
    """
    q_ref, dx = cs.SX.sym("q_ref", 36), cs.SX.sym("dx", 35)
    v, a, f = cs.SX.sym("v", 35), cs.SX.sym("a", 35), cs.SX.sym("f", 3 * len(points))
    qw, qv = q_ref[6], q_ref[3:6]
    rot_ref = (2 * qw * qw - 1) * cs.DM.eye(3) + 2 * (qv @ qv.T) + 2 * qw * _skew(qv)
    rot = rot_ref @ cayley(dx[3:6])
    pos = q_ref[:3] + dx[:3]
    s = q_ref[7:] + dx[6:]
    rnea, positions, velocities = base_rows(model.pin_model, rot, pos, s, v, a, points)
    force, moment = cs.DM.zeros(3), cs.DM.zeros(3)
    for i, point in enumerate(positions):
        fc = f[3 * i: 3 * i + 3]
        force += fc
        moment += cs.cross(point - pos, fc)
    # Body-fixed base rows of J_c^T f: the wrench in the pelvis frame about its origin.
    wrench = cs.vertcat(rot.T @ force, rot.T @ moment)
    eom = rnea - wrench
    return cs.Function("fullbody_node", [q_ref, dx, v, a, f],
                       [eom, cs.vertcat(*positions), cs.reshape(rot, 9, 1), pos,
                        cs.vertcat(*velocities)])


#: Sizes: unknowns per node before the point forces (dx, v, a), interval constraints
#: (joints 29, velocities 35, pelvis position 3, pelvis rotation 3), weights. Those that
#: grow with the P contact points: :class:`StageFunctions` (nz, nparams, ng).
NQ, NI, NW = 105, 70, 7
#: Node parameters before the contact flags (q_ref, v_ref, a_ref) and after them (foot
#: forces 6, COPs 6, free moments 2, floor height, belt velocity, compliance, mu, ramp).
NP_MOTION, NP_PLATES = 106, 19
#: Weight of the point forces' own cost relative to the foot-force tracking.
REGULARISATION = 1e-4
#: Unit of the force unknowns, N: forces of hundreds of N as numbers of order one (on
#: subject01's cycle 63 Ipopt iterations instead of 81 with N; 500 N: 60 iterations
#: but twice the linear-solver time).
FORCE_UNIT = 100.0


@dataclass(frozen=True, eq=False)
class StageFunctions:
    """CasADi functions of one node and one interval (the NLP is assembled from them).

    Attributes:
        points: The P contact frames, in the order of the forces.
        node: ``(z, p, w) -> (g, cost)``: z (nz,) unknowns (dx, v, a, f / FORCE_UNIT),
            p (nparams,) parameters (:func:`~predgait.problems.fullbody_tracking.
            node_parameters`), w (NW,) weights; g (ng,) node constraints (base rows 6,
            contact heights P, friction pyramid 4 P), cost (scalar).
        node_jacobian: ``(z, p, w) -> dg/dz`` (ng, nz).
        node_gradient: ``(z, p, w) -> dcost/dz`` (nz,).
        node_hessian: ``(z, p, w, sigma, lam, mu)``: upper triangle of the Hessian of
            sigma cost + lam.g + mu.(R v_lin).
        interval: ``(z0, z1, q0, q1, h) -> g`` (NI,): the trapezoidal collocation of one
            interval (q0, q1 the nodes' reference configurations, h s).
        interval_jacobian: ``(z0, z1, q0, q1, h) -> dg/d(z0, z1)`` (NI, 2 nz).
        rotation_hessian: ``(q0, q1, c0, c1, lam)``: Hessian of lam.vee(skew(R0^T R1))
            in (c0, c1).
    """

    points: tuple[str, ...]
    node: cs.Function
    node_jacobian: cs.Function
    node_gradient: cs.Function
    node_hessian: cs.Function
    interval: cs.Function
    interval_jacobian: cs.Function
    rotation_hessian: cs.Function

    @property
    def nz(self) -> int:
        """Unknowns per node."""
        return NQ + 3 * len(self.points)

    @property
    def nparams(self) -> int:
        """Parameters per node."""
        return NP_MOTION + len(self.points) + NP_PLATES

    @property
    def ng(self) -> int:
        """Constraints per node."""
        return 6 + 5 * len(self.points)


@functools.lru_cache(maxsize=4)
def stage_functions(model: Model3D, points: tuple[str, ...] = POINTS) -> StageFunctions:
    """The node and interval functions of :class:`StageFunctions` (SX, built once)."""
    node = node_function(model, points)
    feet = point_feet(points)
    count = len(points)
    nz = NQ + 3 * count
    z, p, w = cs.SX.sym("z", nz), cs.SX.sym("p", NP_MOTION + count + NP_PLATES), cs.SX.sym("w", NW)
    dx, v, a, f = z[:35], z[35:70], z[70:105], FORCE_UNIT * z[105:]
    q_ref, v_ref, a_ref, on = p[:36], p[36:71], p[71:NP_MOTION], p[NP_MOTION:NP_MOTION + count]
    rest = p[NP_MOTION + count:]
    force_t, cop, free_moment = rest[:6], rest[6:12], rest[12:14]
    ground_z, belt, compliance, mu, ramp = rest[14], rest[15], rest[16], rest[17], rest[18]
    eom, points_xyz, rot, pos, point_vel = node(q_ref, dx, v, a, f)
    fz = f[2::3]
    heights = points_xyz[2::3] + on * fz * compliance - ground_z
    friction = cs.vertcat(f[0::3] - mu * fz, -f[0::3] - mu * fz, f[1::3] - mu * fz,
                          -f[1::3] - mu * fz)
    g = cs.vertcat(eom, heights, friction)
    cost = w[0] * (cs.sumsqr(dx[6:]) + cs.sumsqr(2 * dx[3:6])) + w[1] * cs.sumsqr(dx[:3])
    cost += w[2] * cs.sumsqr(v - v_ref) + w[3] * cs.sumsqr(a - a_ref)
    for foot in (0, 1):
        cols = [c for c in range(count) if feet[c] == foot]
        total = sum(f[3 * c: 3 * c + 3] for c in cols)
        moment = sum(cs.cross(points_xyz[3 * c: 3 * c + 3] - cop[3 * foot: 3 * foot + 3],
                              f[3 * c: 3 * c + 3]) for c in cols)
        target = cs.vertcat(0, 0, free_moment[foot])
        cost += w[4] * cs.sumsqr(total - force_t[3 * foot: 3 * foot + 3])
        cost += w[5] * cs.sumsqr(moment - target)
    for c in range(count):
        slip = point_vel[3 * c: 3 * c + 2] - cs.vertcat(belt, 0)
        coulomb = -mu * f[3 * c + 2] * adams_step(slip, -ramp, -1.0, ramp, 1.0)
        cost += w[6] * on[c] * cs.sumsqr(f[3 * c: 3 * c + 2] - coulomb)
    # The forces between points of one foot that cancel (a squeeze along the line
    # between them) change nothing else: a small cost on every force fixes them.
    cost += w[4] * REGULARISATION * cs.sumsqr(f)
    u = cs.reshape(rot, 3, 3) @ v[:3]
    node_f = cs.Function("tracking_node", [z, p, w], [g, cost])
    node_jac = cs.Function("tracking_node_jacobian", [z, p, w], [cs.jacobian(g, z)])
    node_grad = cs.Function("tracking_node_gradient", [z, p, w], [cs.gradient(cost, z)])
    sigma, lam, mu3 = cs.SX.sym("sigma"), cs.SX.sym("lam", 6 + 5 * count), cs.SX.sym("mu", 3)
    lagrangian = sigma * cost + cs.dot(lam, g) + cs.dot(mu3, u)
    hess = cs.Function("tracking_node_hessian", [z, p, w, sigma, lam, mu3],
                       [cs.triu(cs.hessian(lagrangian, z)[0])])
    q0, q1 = cs.SX.sym("q0", 36), cs.SX.sym("q1", 36)
    c0, c1, lam_r = cs.SX.sym("c0", 3), cs.SX.sym("c1", 3), cs.SX.sym("lam_r", 3)
    rel = (_rotation(q0) @ cayley(c0)).T @ (_rotation(q1) @ cayley(c1))
    rot_lag = cs.dot(lam_r, _vee_skew(rel))
    rot_hess = cs.Function("tracking_rotation_hessian", [q0, q1, c0, c1, lam_r],
                           [cs.hessian(rot_lag, cs.vertcat(c0, c1))[0]])
    z0, z1, step = cs.SX.sym("z0", nz), cs.SX.sym("z1", nz), cs.SX.sym("h")
    g_int = _interval(z0, z1, q0, q1, step)
    interval = cs.Function("tracking_interval", [z0, z1, q0, q1, step], [g_int])
    interval_jac = cs.Function("tracking_interval_jacobian", [z0, z1, q0, q1, step],
                               [cs.jacobian(g_int, cs.vertcat(z0, z1))])
    return StageFunctions(points, node_f, node_jac, node_grad, hess, interval, interval_jac,
                          rot_hess)


def _interval(z0, z1, q0, q1, h):
    """Trapezoidal collocation of one interval (NI,): joints, v, pelvis position, rotation."""
    poses = []
    for z, q in ((z0, q0), (z1, q1)):
        poses.append((_rotation(q) @ cayley(z[3:6]), q[:3] + z[:3]))
    (r0, p0), (r1, p1) = poses
    v0, v1 = z0[35:70], z1[35:70]
    return cs.vertcat(
        q1[7:] + z1[6:35] - q0[7:] - z0[6:35] - h / 2 * (v1[6:] + v0[6:]),
        v1 - v0 - h / 2 * (z1[70:105] + z0[70:105]),
        p1 - p0 - h / 2 * (r1 @ v1[:3] + r0 @ v0[:3]),
        _vee_skew(r0.T @ r1) - h / 2 * (v1[3:6] + v0[3:6]))


def _rotation(q):
    """Rotation matrix of the quaternion q[3:7] = (x, y, z, w) (CasADi)."""
    qw, qv = q[6], q[3:6]
    return (2 * qw * qw - 1) * cs.DM.eye(3) + 2 * (qv @ qv.T) + 2 * qw * _skew(qv)


def _vee_skew(m):
    """The vee of the skew part of a 3x3 matrix: (sin angle) axis for a rotation."""
    return 0.5 * cs.vertcat(m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1])


def cayley_numeric(c: np.ndarray) -> np.ndarray:
    """:func:`~predgait.problems.fullbody_tracking_stage.cayley` in NumPy."""
    k = np.array([[0, -c[2], c[1]], [c[2], 0, -c[0]], [-c[1], c[0], 0]])
    return np.eye(3) + 2.0 / (1.0 + c @ c) * (k + k @ k)


def corrected_configuration(q_ref: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """Configuration q (36,) from q_ref (36,) and the correction dx = (dp, c, ds) (35,)."""
    rot = pin.Quaternion(q_ref[6], *q_ref[3:6]).toRotationMatrix() @ cayley_numeric(dx[3:6])
    quat = pin.Quaternion(rot).normalized().coeffs()
    return np.concatenate([q_ref[:3] + dx[:3], quat, q_ref[7:] + dx[6:]])


def contact_inverse_dynamics(model: Model3D, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                             forces: np.ndarray, points: tuple[str, ...] = POINTS
                             ) -> np.ndarray:
    """(N, 35) Pinocchio RNEA(q, v, a) - sum_c J_c^T f_c, lab forces (N, P, 3) on ``points``."""
    pm, pdata = model.pin_model, model.pin_model.createData()
    ids = [model.frame_id(p) for p in points]
    out = np.empty((q.shape[0], model.nv))
    frame = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    for k in range(q.shape[0]):
        tau = pin.rnea(pm, pdata, q[k], v[k], a[k]).copy()
        pin.computeJointJacobians(pm, pdata, q[k])
        pin.updateFramePlacements(pm, pdata)
        for fid, force in zip(ids, forces[k], strict=True):
            if force.any():
                tau -= pin.getFrameJacobian(pm, pdata, fid, frame)[:3].T @ force
        out[k] = tau
    return out
