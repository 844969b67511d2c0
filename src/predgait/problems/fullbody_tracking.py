"""Whole-body tracking with contacts: a dynamically consistent walk (CasADi + Ipopt, ADAM).

The 35-DOF body (:mod:`predgait.models.fullbody`) with its pelvis a free flyer and no
residual actuators. Unknowns at every node k of the measured frames: the corrected
configuration, velocity v_k and acceleration a_k (Pinocchio's: pelvis linear and angular
velocity in the pelvis frame, then the joint rates) and the 3D forces f_c on the sole
points ``heel_contact_*`` / ``toe_contact_*`` that are in contact. Implicit dynamics:
only the 6 floating-base rows of the equations of motion are constraints,

    M(q)_{0:6,:} a + h(q, v)_{0:6} - sum_c J_c(q)_{:, 0:6}^T f_c = 0,

(Featherstone 2008, Rigid Body Dynamics Algorithms, ch. 9: a floating base is driven only
by the external forces); the joint torques are outputs, the remaining rows of
RNEA(q, v, a) - sum J_c^T f_c, evaluated by Pinocchio after the solve. This is the
residual-reduction problem of OpenSim's RRA and AddBiomechanics (Werling et al. 2023,
PLoS ONE 18:e0295152) solved by optimal control with the residuals held at zero.

Configuration: pelvis position p_k = p_ref,k + dp_k (lab, m), orientation
R_k = R_ref,k C(c_k) with the Cayley map C(c) = I + 2 / (1 + c.c) ([c]x + [c]x^2)
(rotation angle 2 atan |c|, exactly orthogonal and smooth), joints s_k = s_ref,k + ds_k.

Trapezoidal collocation between nodes (step h): s, v by the trapezoidal rule on their
rates, p_{k+1} - p_k = h/2 (R_k v_lin,k + R_k+1 v_lin,k+1), and the pelvis rotation
vee(skew(R_k^T R_k+1)) = h/2 (w_k + w_k+1) (the skew part of the rotation over one step,
sin(angle) axis, equal to the integrated body rate to O(h^3)).

Contacts (per point, per node, from the plate-detected stance of its foot and the
measured point height): in contact, the normal force f_z >= 0 within the friction pyramid
|f_x|, |f_y| <= mu f_z and the point at the depth where the forward engine's contact
spring carries it, z = ground_z - f_z / k (:class:`~predgait.dynamics.contact.
ImpactContact` with exponent 1); out of contact, f = 0 and z >= ground_z.

Cost (each term a mean over nodes of squared errors over a scale, Bryson-like): joint and
pelvis angles (deg), pelvis position (m), each foot's force and its moment about the
plate's COP against the plate (force and free moment; % body weight), the tangential
force of each contact point against the forward engine's Coulomb law at its slip relative
to the floor, -mu f_z STEP(v_t, -v_s, -1, v_s, 1) (% body weight: the engine then starts
from the solved friction), and a small regularisation of v and a toward the measured
ones (which also removes the trapezoidal rule's alternating mode).
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass

import casadi as cs
import numpy as np
import pinocchio as pin

from predgait.blas_threads import one_blas_thread
from predgait.dynamics.contact import adams_step
from predgait.errors import SolveFailed
from predgait.models.fullbody import CONTACTS
from predgait.models.loading3d import Model3D, adam_kindyn

#: Contact points, in the order of the force arrays: right heel, right toe, left heel,
#: left toe; their feet.
POINTS = ("heel_contact_r", "toe_contact_r", "heel_contact_l", "toe_contact_l")
POINT_FOOT = ("r", "r", "l", "l")
assert set(POINTS) == set(CONTACTS)


@dataclass(frozen=True)
class TrackingWeights:
    """Scales of the cost terms: the error that costs one unit (Bryson's rule).

    Attributes:
        angle_deg: Joint and pelvis angle error, deg.
        position_m: Pelvis position error, m.
        force_bw: Foot force error, fraction of body weight.
        moment_bw_m: Foot moment error about the plate COP, body weight x m.
        friction_bw: Tangential contact force against the engine's friction law at the
            point's slip, fraction of body weight.
        velocity_rad_s: Regularisation of v toward the measured one, rad/s (and m/s).
        acceleration_rad_s2: Regularisation of a toward the measured one, rad/s^2.
    """

    angle_deg: float = 1.0
    position_m: float = 0.01
    force_bw: float = 0.02
    moment_bw_m: float = 0.004
    friction_bw: float = 0.02
    velocity_rad_s: float = 2.0
    acceleration_rad_s2: float = 50.0


@dataclass(frozen=True, eq=False)
class TrackingData:
    """What the problem tracks, on its nodes.

    Attributes:
        time: (N,) s, equally spaced.
        q, v, a: (N, 36), (N, 35), (N, 35) measured motion (Pinocchio's conventions).
        contact: (N, 4) bool, point of :data:`POINTS` in contact.
        force: (N, 2, 3) N, plate force on the right and left foot (lab).
        cop: (N, 2, 3) m, its COP (any point on a foot without load).
        free_moment: (N, 2) N m, vertical free moment of each foot's plate.
        ground_z: m, floor height. belt_velocity: m/s along X of the floor.
        stiffness: N/m, contact spring of the forward engine (exponent 1).
        friction: Coulomb coefficient of the friction pyramid and law.
        slip_transition: m/s, slip over which the engine's friction ramps to mu f_z.
    """

    time: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    contact: np.ndarray
    force: np.ndarray
    cop: np.ndarray
    free_moment: np.ndarray
    ground_z: float
    belt_velocity: float = 0.0
    stiffness: float = 2.0e5
    friction: float = 0.8
    slip_transition: float = 0.05

    @property
    def nodes(self) -> int:
        """Number of nodes N."""
        return self.time.size


@dataclass(frozen=True, eq=False)
class TrackingSolution:
    """A dynamically consistent whole-body motion.

    Attributes:
        time: (N,) s. q: (N, 36). v, a: (N, 35).
        forces: (N, 4, 3) N, lab forces on :data:`POINTS`.
        tau: (N, 35) Pinocchio RNEA(q, v, a) - sum J_c^T f_c: rows 0..5 the pelvis
            residual (N, N m; zero to the solver's tolerance), rows 6.. joint torques, N m.
        iterations: Ipopt iterations. seconds: wall time of the solve (build excluded).
        build_seconds: wall time of building the NLP (symbolic functions cached).
        status: Ipopt's return status.
    """

    time: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    forces: np.ndarray
    tau: np.ndarray
    iterations: int
    seconds: float
    build_seconds: float
    status: str

    def foot_forces(self) -> np.ndarray:
        """(N, 2, 3) N, total force on the right and left foot."""
        return np.stack([self.forces[:, 0] + self.forces[:, 1],
                         self.forces[:, 2] + self.forces[:, 3]], axis=1)


def _skew(w):
    return cs.vertcat(cs.horzcat(0, -w[2], w[1]), cs.horzcat(w[2], 0, -w[0]),
                      cs.horzcat(-w[1], w[0], 0))


def cayley(c):
    """Rotation matrix of the Cayley vector c (3,): I + 2/(1 + c.c) ([c]x + [c]x^2)."""
    k = _skew(c)
    return cs.DM.eye(3) + 2.0 / (1.0 + cs.dot(c, c)) * (k + k @ k)


def cayley_numeric(c: np.ndarray) -> np.ndarray:
    """:func:`cayley` in NumPy."""
    k = np.array([[0, -c[2], c[1]], [c[2], 0, -c[0]], [-c[1], c[0], 0]])
    return np.eye(3) + 2.0 / (1.0 + c @ c) * (k + k @ k)


def corrected_configuration(q_ref: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """Configuration q (36,) from q_ref (36,) and the correction dx = (dp, c, ds) (35,)."""
    rot = pin.Quaternion(q_ref[6], *q_ref[3:6]).toRotationMatrix() @ cayley_numeric(dx[3:6])
    quat = pin.Quaternion(rot).normalized().coeffs()
    return np.concatenate([q_ref[:3] + dx[:3], quat, q_ref[7:] + dx[6:]])


@functools.lru_cache(maxsize=4)
def node_function(model: Model3D) -> cs.Function:
    """``node(q_ref, dx, v, a, f) -> (eom, points, rot, pos, point_velocities)``.

    q_ref (36,), dx (35,) correction, v, a (35,), f (12,) forces on :data:`POINTS`;
    eom (6,) the floating-base rows (N, N m, pelvis frame); points (12,) lab positions of
    the contact points; rot (9,) R column-major; pos (3,) pelvis position;
    point_velocities (12,) lab velocities of the contact points.
    """
    kindyn = adam_kindyn(model)
    q_ref, dx = cs.SX.sym("q_ref", 36), cs.SX.sym("dx", 35)
    v, a, f = cs.SX.sym("v", 35), cs.SX.sym("a", 35), cs.SX.sym("f", 12)
    qw, qv = q_ref[6], q_ref[3:6]
    rot_ref = (2 * qw * qw - 1) * cs.DM.eye(3) + 2 * (qv @ qv.T) + 2 * qw * _skew(qv)
    rot = rot_ref @ cayley(dx[3:6])
    pos = q_ref[:3] + dx[:3]
    s = q_ref[7:] + dx[6:]
    frame = cs.vertcat(cs.horzcat(rot, pos), cs.DM([[0, 0, 0, 1]]))
    mass = kindyn.mass_matrix(frame, s)
    bias = kindyn.bias_force(frame, s, v[:6], v[6:])
    points, velocities = [], []
    force, moment = cs.DM.zeros(3), cs.DM.zeros(3)
    for i, name in enumerate(POINTS):
        pose = kindyn.forward_kinematics(name, frame, s)
        point = pose[:3, 3]
        points.append(point)
        # Body-fixed representation: the frame's velocity in its own axes; to the lab.
        velocities.append(pose[:3, :3] @ (kindyn.jacobian(name, frame, s)[:3, :] @ v))
        fc = f[3 * i: 3 * i + 3]
        force += fc
        moment += cs.cross(point - pos, fc)
    # Body-fixed base rows of J_c^T f: the wrench in the pelvis frame about its origin.
    wrench = cs.vertcat(rot.T @ force, rot.T @ moment)
    eom = mass[:6, :] @ a + bias[:6] - wrench
    return cs.Function("fullbody_node", [q_ref, dx, v, a, f],
                       [eom, cs.vertcat(*points), cs.reshape(rot, 9, 1), pos,
                        cs.vertcat(*velocities)])


def _initial_forces(data: TrackingData) -> np.ndarray:
    """(N, 12): each foot's plate force shared by its points in contact, inside the cone."""
    out = np.zeros((data.nodes, 4, 3))
    for foot, cols in ((0, (0, 1)), (1, (2, 3))):
        on = data.contact[:, cols]
        count = np.maximum(on.sum(axis=1), 1)
        force = data.force[:, foot].copy()
        force[:, 2] = np.maximum(force[:, 2], 0.0)
        limit = data.friction * force[:, 2:3] * 0.99
        force[:, :2] = np.clip(force[:, :2], -limit, limit)
        for j, c in enumerate(cols):
            out[:, c] = np.where(on[:, j:j + 1], force / count[:, None], 0.0)
    return out.reshape(data.nodes, 12)


#: Sizes: unknowns per node (dx, v, a, f / FORCE_UNIT), node parameters, node constraints (base
#: rows 6, contact heights 4, friction pyramid 16), interval constraints (joints 29,
#: velocities 35, pelvis position 3, pelvis rotation 3), weights.
NZ, NP, NG, NI, NW = 117, 129, 26, 70, 7
#: Weight of the point forces' own cost relative to the foot-force tracking.
REGULARISATION = 1e-4
#: Unit of the force unknowns, N: forces of hundreds of N as numbers of order one (on
#: subject01's cycle 63 Ipopt iterations instead of 81 with N; 500 N: 60 iterations
#: but twice the linear-solver time).
FORCE_UNIT = 100.0


def _node_parameters(data: TrackingData) -> np.ndarray:
    """(NP, N) per-node parameters.

    q_ref, v_ref, a_ref, contact, force, cop, free moment, floor height, belt velocity,
    1/stiffness, friction, slip transition.
    """
    n = data.nodes
    const = np.tile([[data.ground_z], [data.belt_velocity], [1.0 / data.stiffness],
                     [data.friction], [data.slip_transition]], (1, n))
    return np.vstack([data.q.T, data.v.T, data.a.T, data.contact.T.astype(float),
                      data.force.reshape(n, 6).T, data.cop.reshape(n, 6).T,
                      data.free_moment.T, const])


def _weight_vector(weights: TrackingWeights, body_weight: float) -> np.ndarray:
    w = weights
    return 1.0 / np.array([np.radians(w.angle_deg), w.position_m, w.velocity_rad_s,
                           w.acceleration_rad_s2, w.force_bw * body_weight,
                           w.moment_bw_m * body_weight, w.friction_bw * body_weight]) ** 2


@dataclass(frozen=True, eq=False)
class StageFunctions:
    """CasADi functions of one node and one interval (the NLP is assembled from them).

    Attributes:
        node: ``(z, p, w) -> (g, cost)``: z (NZ,) unknowns, p (NP,) parameters, w (NW,)
            weights; g (NG,) node constraints, cost (scalar).
        node_jacobian: ``(z, p, w) -> dg/dz`` (NG, NZ).
        node_gradient: ``(z, p, w) -> dcost/dz`` (NZ,).
        node_hessian: ``(z, p, w, sigma, lam, mu)``: upper triangle of the Hessian of
            sigma cost + lam.g + mu.(R v_lin).
        interval: ``(z0, z1, q0, q1, h) -> g`` (NI,): the trapezoidal collocation of one
            interval (q0, q1 the nodes' reference configurations, h s).
        interval_jacobian: ``(z0, z1, q0, q1, h) -> dg/d(z0, z1)`` (NI, 2 NZ).
        rotation_hessian: ``(q0, q1, c0, c1, lam)``: Hessian of lam.vee(skew(R0^T R1))
            in (c0, c1).
    """

    node: cs.Function
    node_jacobian: cs.Function
    node_gradient: cs.Function
    node_hessian: cs.Function
    interval: cs.Function
    interval_jacobian: cs.Function
    rotation_hessian: cs.Function


@functools.lru_cache(maxsize=4)
def stage_functions(model: Model3D) -> StageFunctions:
    """The node and interval functions of :class:`StageFunctions` (SX, built once)."""
    node = node_function(model)
    z, p, w = cs.SX.sym("z", NZ), cs.SX.sym("p", NP), cs.SX.sym("w", NW)
    dx, v, a, f = z[:35], z[35:70], z[70:105], FORCE_UNIT * z[105:]
    q_ref, v_ref, a_ref, on = p[:36], p[36:71], p[71:106], p[106:110]
    force_t, cop, free_moment = p[110:116], p[116:122], p[122:124]
    ground_z, belt, compliance, mu, ramp = p[124], p[125], p[126], p[127], p[128]
    eom, points, rot, pos, point_vel = node(q_ref, dx, v, a, f)
    fz = f[2::3]
    heights = points[2::3] + on * fz * compliance - ground_z
    friction = cs.vertcat(f[0::3] - mu * fz, -f[0::3] - mu * fz, f[1::3] - mu * fz,
                          -f[1::3] - mu * fz)
    g = cs.vertcat(eom, heights, friction)
    cost = w[0] * (cs.sumsqr(dx[6:]) + cs.sumsqr(2 * dx[3:6])) + w[1] * cs.sumsqr(dx[:3])
    cost += w[2] * cs.sumsqr(v - v_ref) + w[3] * cs.sumsqr(a - a_ref)
    for foot in (0, 1):
        cols = (2 * foot, 2 * foot + 1)
        total = sum(f[3 * c: 3 * c + 3] for c in cols)
        moment = sum(cs.cross(points[3 * c: 3 * c + 3] - cop[3 * foot: 3 * foot + 3],
                              f[3 * c: 3 * c + 3]) for c in cols)
        target = cs.vertcat(0, 0, free_moment[foot])
        cost += w[4] * cs.sumsqr(total - force_t[3 * foot: 3 * foot + 3])
        cost += w[5] * cs.sumsqr(moment - target)
    for c in range(4):
        slip = point_vel[3 * c: 3 * c + 2] - cs.vertcat(belt, 0)
        coulomb = -mu * f[3 * c + 2] * adams_step(slip, -ramp, -1.0, ramp, 1.0)
        cost += w[6] * on[c] * cs.sumsqr(f[3 * c: 3 * c + 2] - coulomb)
    # The forces between two points of one foot that cancel (a squeeze along the
    # heel-toe line) change nothing else: a small cost on every force fixes them.
    cost += w[4] * REGULARISATION * cs.sumsqr(f)
    u = cs.reshape(rot, 3, 3) @ v[:3]
    node_f = cs.Function("tracking_node", [z, p, w], [g, cost])
    node_jac = cs.Function("tracking_node_jacobian", [z, p, w], [cs.jacobian(g, z)])
    node_grad = cs.Function("tracking_node_gradient", [z, p, w], [cs.gradient(cost, z)])
    sigma, lam, mu3 = cs.SX.sym("sigma"), cs.SX.sym("lam", NG), cs.SX.sym("mu", 3)
    lagrangian = sigma * cost + cs.dot(lam, g) + cs.dot(mu3, u)
    hess = cs.Function("tracking_node_hessian", [z, p, w, sigma, lam, mu3],
                       [cs.triu(cs.hessian(lagrangian, z)[0])])
    q0, q1 = cs.SX.sym("q0", 36), cs.SX.sym("q1", 36)
    c0, c1, lam_r = cs.SX.sym("c0", 3), cs.SX.sym("c1", 3), cs.SX.sym("lam_r", 3)
    rel = (_rotation(q0) @ cayley(c0)).T @ (_rotation(q1) @ cayley(c1))
    rot_lag = cs.dot(lam_r, _vee_skew(rel))
    rot_hess = cs.Function("tracking_rotation_hessian", [q0, q1, c0, c1, lam_r],
                           [cs.hessian(rot_lag, cs.vertcat(c0, c1))[0]])
    z0, z1, step = cs.SX.sym("z0", NZ), cs.SX.sym("z1", NZ), cs.SX.sym("h")
    g_int = _interval(z0, z1, q0, q1, step)
    interval = cs.Function("tracking_interval", [z0, z1, q0, q1, step], [g_int])
    interval_jac = cs.Function("tracking_interval_jacobian", [z0, z1, q0, q1, step],
                               [cs.jacobian(g_int, cs.vertcat(z0, z1))])
    return StageFunctions(node_f, node_jac, node_grad, hess, interval, interval_jac, rot_hess)


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


def _interval_columns(n: int) -> cs.DM:
    """Sparse (2 NZ (N-1), N NZ) selection of (z_k, z_k+1) for every interval k."""
    rows = np.arange(2 * NZ * (n - 1))
    cols = (np.arange(n - 1)[:, None] * NZ + np.arange(2 * NZ)[None]).ravel()
    return cs.DM(cs.Sparsity.triplet(2 * NZ * (n - 1), NZ * n, rows.tolist(),
                                     cols.tolist()), 1.0)


def _scatter(n: int) -> cs.DM:
    """Sparse (6 (N-1), N NZ) selection of (c_k, c_k+1) for every interval k."""
    rows, cols = [], []
    for k in range(n - 1):
        for i in range(3):
            rows += [6 * k + i, 6 * k + 3 + i]
            cols += [NZ * k + 3 + i, NZ * (k + 1) + 3 + i]
    return cs.DM(cs.Sparsity.triplet(6 * (n - 1), NZ * n, rows, cols), 1.0)


@dataclass(frozen=True, eq=False)
class TrackingNLP:
    """The NLP of :func:`solve_tracking` with its derivative functions and bounds.

    Attributes:
        nlp: ``{"x", "f", "g"}`` MX expressions. x0, lbx, ubx, lbg, ubg: arrays.
        derivatives: nlpsol options ``hess_lag``, ``jac_g``, ``grad_f`` assembled from
            the stage functions.
    """

    nlp: dict
    derivatives: dict
    x0: np.ndarray
    lbx: np.ndarray
    ubx: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray


def tracking_nlp(model: Model3D, data: TrackingData,
                 weights: TrackingWeights = TrackingWeights()) -> TrackingNLP:
    """The tracking NLP (module docstring), its derivatives from one node and one interval.

    Decision vector: node-major, z_k = (dx_k, v_k, a_k, f_k / FORCE_UNIT) (NZ each).
    Constraints: NG per node, then NI per interval. The constraint Jacobian, the cost gradient and
    the Hessian of the Lagrangian are assembled from one node's and one interval's
    symbolic derivatives (:func:`stage_functions`), so the symbolic work does not grow
    with the number of nodes and no derivative is taken through the mapped calls.
    """
    n = data.nodes
    h = float(np.mean(np.diff(data.time)))
    stage = stage_functions(model)
    params = _node_parameters(data)
    w = _weight_vector(weights, model.total_mass() * model.gravity)
    x, no_p = cs.MX.sym("x", NZ * n), cs.MX.sym("p", 0)
    z = cs.reshape(x, NZ, n)
    qs = data.q.T
    g_node, cost = stage.node.map(n)(z, params, w)
    int_args = (z[:, :-1], z[:, 1:], qs[:, :-1], qs[:, 1:], h)
    g = cs.vertcat(cs.vec(g_node), cs.vec(stage.interval.map(n - 1)(*int_args)))
    jac_node = stage.node_jacobian.map(n)(z, params, w)
    grad_node = stage.node_gradient.map(n)(z, params, w)
    jac_int = stage.interval_jacobian.map(n - 1)(*int_args)
    jacobian = cs.vertcat(cs.diagcat(*cs.horzsplit(jac_node, NZ)),
                          cs.diagcat(*cs.horzsplit(jac_int, 2 * NZ)) @ _interval_columns(n))
    # Hessian of the Lagrangian.
    sigma, lam = cs.MX.sym("sigma"), cs.MX.sym("lam", g.size1())
    lam_node = cs.reshape(lam[:NG * n], NG, n)
    lam_int = cs.reshape(lam[NG * n:], NI, n - 1)
    lam_pos, lam_rot = lam_int[64:67, :], lam_int[67:70, :]
    zero = cs.MX.zeros(3, 1)
    mu = -h / 2 * (cs.horzcat(lam_pos, zero) + cs.horzcat(zero, lam_pos))
    blocks = stage.node_hessian.map(n)(z, params, w, sigma / n, lam_node, mu)
    hessian = cs.diagcat(*cs.horzsplit(blocks, NZ))
    rblocks = stage.rotation_hessian.map(n - 1)(qs[:, :-1], qs[:, 1:], z[3:6, :-1],
                                                z[3:6, 1:], lam_rot)
    scatter = _scatter(n)
    hessian += cs.triu(scatter.T @ cs.diagcat(*cs.horzsplit(rblocks, 6)) @ scatter)
    derivatives = {
        "hess_lag": cs.Function("nlp_hess_l", [x, no_p, sigma, lam], [hessian],
                                ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"]),
        "jac_g": cs.Function("nlp_jac_g", [x, no_p], [g, jacobian], ["x", "p"],
                             ["g", "jac_g_x"]),
        "grad_f": cs.Function("nlp_grad_f", [x, no_p],
                              [cs.sum2(cost) / n, cs.vec(grad_node) / n], ["x", "p"],
                              ["f", "grad_f_x"])}
    # Bounds: contact heights, friction pyramid, no force off contact.
    on = data.contact.T.astype(bool)
    lbg_node, ubg_node = np.zeros((NG, n)), np.zeros((NG, n))
    ubg_node[6:10] = np.where(on, 0.0, np.inf)
    lbg_node[10:] = -np.inf
    lbx, ubx = np.full((n, NZ), -np.inf), np.full((n, NZ), np.inf)
    on_points = np.repeat(data.contact[:, :, None], 3, axis=2).reshape(n, 12)
    lbx[:, 105:] = np.where(on_points, np.tile([-np.inf, -np.inf, 0.0], 4), 0.0)
    ubx[:, 105:] = np.where(on_points, np.inf, 0.0)
    return TrackingNLP(
        {"x": x, "f": cs.sum2(cost) / n, "g": g}, derivatives,
        np.hstack([np.zeros((n, 35)), data.v, data.a,
                   _initial_forces(data) / FORCE_UNIT]).ravel(),
        lbx.ravel(), ubx.ravel(),
        np.concatenate([lbg_node.ravel(order="F"), np.zeros(NI * (n - 1))]),
        np.concatenate([ubg_node.ravel(order="F"), np.zeros(NI * (n - 1))]))


def solve_tracking(model: Model3D, data: TrackingData,
                   weights: TrackingWeights = TrackingWeights(), *,
                   max_iter: int = 200, tol: float = 1e-8,
                   print_level: int = 0) -> TrackingSolution:
    """Solve the tracking problem (:func:`tracking_nlp`) with Ipopt, exact Hessian.

    Raises:
        SolveFailed: Ipopt did not converge (``best`` is the last iterate's solution).
    """
    start = time.perf_counter()
    n = data.nodes
    problem = tracking_nlp(model, data, weights)
    options = {"print_time": False, **problem.derivatives,
               "ipopt": {"print_level": print_level, "sb": "yes", "max_iter": max_iter,
                         "tol": tol, "constr_viol_tol": 1e-9, "mu_strategy": "adaptive"}}
    solver = cs.nlpsol("fullbody_tracking", "ipopt", problem.nlp, options)
    built = time.perf_counter()
    with one_blas_thread():  # MUMPS' fronts are small: BLAS threads only cost here
        result = solver(x0=problem.x0, lbx=problem.lbx, ubx=problem.ubx, lbg=problem.lbg,
                        ubg=problem.ubg)
    seconds = time.perf_counter() - built
    stats = solver.stats()
    solution = _unpack(model, data, np.asarray(result["x"]).reshape(n, NZ), stats, seconds,
                       built - start)
    if not stats["success"]:
        raise SolveFailed(f"whole-body tracking did not converge: {stats['return_status']} "
                          f"after {stats['iter_count']} iterations.", best=solution)
    return solution


def _unpack(model, data, z, stats, seconds, build_seconds) -> TrackingSolution:
    dx, v, a = z[:, :35], z[:, 35:70], z[:, 70:105]
    f = FORCE_UNIT * z[:, 105:].reshape(-1, 4, 3)
    q = np.array([corrected_configuration(qr, d) for qr, d in zip(data.q, dx, strict=True)])
    return TrackingSolution(data.time.copy(), q, v.copy(), a.copy(), f.copy(),
                            contact_inverse_dynamics(model, q, v, a, f),
                            int(stats["iter_count"]), seconds, build_seconds,
                            str(stats["return_status"]))


def contact_inverse_dynamics(model: Model3D, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                             forces: np.ndarray) -> np.ndarray:
    """(N, 35) Pinocchio RNEA(q, v, a) - sum_c J_c^T f_c with lab forces (N, 4, 3) on POINTS."""
    pm, pdata = model.pin_model, model.pin_model.createData()
    ids = [model.frame_id(p) for p in POINTS]
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
