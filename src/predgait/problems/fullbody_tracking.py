"""Whole-body tracking with contacts: a dynamically consistent walk (CasADi + Ipopt).

The 35-DOF body (:mod:`predgait.models.fullbody`) with its pelvis a free flyer and no
residual actuators. Unknowns at every node k of the measured frames: the corrected
configuration, velocity v_k and acceleration a_k (Pinocchio's: pelvis linear and angular
velocity in the pelvis frame, then the joint rates) and the 3D forces f_c on the sole
points that are in contact (``TrackingData.points``: by default ``heel_contact_*`` /
``toe_contact_*`` on each foot's centre line, or the medial and lateral points
:data:`~predgait.models.fullbody.SOLE_EDGES`, which also support a foot about its
heel-toe line). Implicit dynamics:
only the 6 floating-base rows of the equations of motion are constraints,

    M(q)_{0:6,:} a + h(q, v)_{0:6} - sum_c J_c(q)_{:, 0:6}^T f_c = 0,

(Featherstone 2008, Rigid Body Dynamics Algorithms, ch. 9: a floating base is driven only
by the external forces), written as the pelvis rows of one RNEA pass
(:mod:`~predgait.problems.fullbody_tracking_rnea`); the joint torques are outputs, the
remaining rows of RNEA(q, v, a) - sum J_c^T f_c, evaluated by Pinocchio after the solve. This is the
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
ones. Issue 27 (:mod:`~predgait.problems.fullbody_tracking_smooth`, constant Hessian):
the joint torques against the measured inverse dynamics (linearised about the measured
state), the node-to-node change of a against the measured change (the trapezoidal
rule's period-2h mode a = +A, -A, ... moves no state and otherwise costs almost
nothing: it gave 700 N m alternations of the hip torque), and the second difference of
each point's force. A point that lifts off or lands while its foot stays down has its
normal force capped over ``fade_nodes`` nodes (``fade_limits``): a heel hands its
load to the toe over several nodes instead of within one.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as cs
import numpy as np
import pinocchio as pin

from predgait.blas_threads import one_blas_thread
from predgait.errors import SolveFailed
from predgait.models.loading3d import Model3D
from predgait.problems import ipopt_progress
from predgait.problems.fullbody_tracking_smooth import fade_limits, smoothing_terms
from predgait.problems.fullbody_tracking_stage import (  # noqa: F401  (numeric helpers re-exported)
    FORCE_UNIT,
    NI,
    POINTS,
    cayley_numeric,
    contact_inverse_dynamics,
    corrected_configuration,
    point_feet,
    stage_functions,
)


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
        torque_n_m: Joint torque against the measured inverse dynamics, N m (when the
            data carry them; :mod:`~predgait.problems.fullbody_tracking_smooth`).
        acceleration_change_rad_s2: Node-to-node change of a against the measured
            change, rad/s^2 (m/s^2 pelvis): removes the trapezoidal alternating mode.
        force_change_bw: Second difference of each point's force over the nodes,
            fraction of body weight: a contact unloads over several nodes.
    """

    angle_deg: float = 1.0
    position_m: float = 0.01
    force_bw: float = 0.02
    moment_bw_m: float = 0.004
    friction_bw: float = 0.02
    velocity_rad_s: float = 2.0
    acceleration_rad_s2: float = 50.0
    torque_n_m: float = 2.0
    acceleration_change_rad_s2: float = 5.0
    force_change_bw: float = 0.1


@dataclass(frozen=True, eq=False)
class TrackingData:
    """What the problem tracks, on its nodes.

    Attributes:
        time: (N,) s, equally spaced.
        q, v, a: (N, 36), (N, 35), (N, 35) measured motion (Pinocchio's conventions).
        contact: (N, P) bool, point of ``points`` in contact.
        force: (N, 2, 3) N, plate force on the right and left foot (lab).
        cop: (N, 2, 3) m, its COP (any point on a foot without load).
        free_moment: (N, 2) N m, vertical free moment of each foot's plate.
        ground_z: m, floor height. belt_velocity: m/s along X of the floor.
        stiffness: N/m, contact spring of the forward engine (exponent 1).
        friction: Coulomb coefficient of the friction pyramid and law.
        slip_transition: m/s, slip over which the engine's friction ramps to mu f_z.
        points: The P contact frames (names end in the foot's side, ``_r`` / ``_l``).
        tau: (N, 29) N m, measured joint moments (inverse dynamics on the plates), or
            None: no torque term in the cost.
        fade_nodes: a point that lifts off (or lands) while its foot stays on the floor
            carries at most d / (fade_nodes + 1) of 1.5 body weights d nodes before
            (after) the switch: its force fades over this many nodes.
        floor_source: where ``ground_z`` comes from (for the summary).
        plate_z: m, the plates' COP plane (median COP height), or None; ``cop`` lies on
            z = ground_z, the plates' line of action there.
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
    points: tuple[str, ...] = POINTS
    tau: np.ndarray | None = None
    fade_nodes: int = 3
    floor_source: str = ""
    plate_z: float | None = None

    @property
    def nodes(self) -> int:
        """Number of nodes N."""
        return self.time.size


@dataclass(frozen=True, eq=False)
class TrackingSolution:
    """A dynamically consistent whole-body motion.

    Attributes:
        time: (N,) s. q: (N, 36). v, a: (N, 35).
        forces: (N, P, 3) N, lab forces on ``points``.
        tau: (N, 35) Pinocchio RNEA(q, v, a) - sum J_c^T f_c: rows 0..5 the pelvis
            residual (N, N m; zero to the solver's tolerance), rows 6.. joint torques, N m.
        iterations: Solver iterations (both phases). seconds: wall time of the solve
            (build excluded).
        build_seconds: wall time of building the NLP (symbolic functions cached).
        status: The solver's return status (Ipopt's name, FATROP's code).
        points: The P contact frames of ``forces``.
        objective: The NLP's objective at the solution.
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
    points: tuple[str, ...] = POINTS
    objective: float = float("nan")

    def foot_forces(self) -> np.ndarray:
        """(N, 2, 3) N, total force on the right and left foot."""
        return foot_totals(self.forces, self.points)


def foot_totals(forces: np.ndarray, points: tuple[str, ...]) -> np.ndarray:
    """(N, 2, 3): forces (N, P, 3) on ``points`` summed per foot (right, left)."""
    feet = np.array(point_feet(points))
    return np.stack([forces[:, feet == j].sum(axis=1) for j in (0, 1)], axis=1)


def _initial_forces(data: TrackingData) -> np.ndarray:
    """(N, 3 P): each foot's plate force shared by its points in contact, inside the cone."""
    out = np.zeros((data.nodes, len(data.points), 3))
    feet = np.array(point_feet(data.points))
    for foot in (0, 1):
        cols = np.flatnonzero(feet == foot)
        on = data.contact[:, cols]
        count = np.maximum(on.sum(axis=1), 1)
        force = data.force[:, foot].copy()
        force[:, 2] = np.maximum(force[:, 2], 0.0)
        limit = data.friction * force[:, 2:3] * 0.99
        force[:, :2] = np.clip(force[:, :2], -limit, limit)
        for j, c in enumerate(cols):
            out[:, c] = np.where(on[:, j:j + 1], force / count[:, None], 0.0)
    return out.reshape(data.nodes, -1)


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


def _interval_columns(n: int, nz: int) -> cs.DM:
    """Sparse (2 nz (N-1), N nz) selection of (z_k, z_k+1) for every interval k."""
    rows = np.arange(2 * nz * (n - 1))
    cols = (np.arange(n - 1)[:, None] * nz + np.arange(2 * nz)[None]).ravel()
    return cs.DM(cs.Sparsity.triplet(2 * nz * (n - 1), nz * n, rows.tolist(),
                                     cols.tolist()), 1.0)


def _scatter(n: int, nz: int) -> cs.DM:
    """Sparse (6 (N-1), N nz) selection of (c_k, c_k+1) for every interval k."""
    rows, cols = [], []
    for k in range(n - 1):
        for i in range(3):
            rows += [6 * k + i, 6 * k + 3 + i]
            cols += [nz * k + 3 + i, nz * (k + 1) + 3 + i]
    return cs.DM(cs.Sparsity.triplet(6 * (n - 1), nz * n, rows, cols), 1.0)


#: Eigenvalue floor of the clipped node Hessian blocks.
CLIP_MARGIN = 1e-8


class EigenClip(cs.Callback):
    """Node Hessian blocks with their eigenvalues raised to :data:`CLIP_MARGIN`.

    Input: the N blocks' upper triangles side by side (nz, N nz); output: the clipped
    blocks, dense. The Hessian is then positive semi-definite: no inertia correction.
    """

    def __init__(self, sparsity: cs.Sparsity, nz: int, n: int):
        cs.Callback.__init__(self)
        self.sparsity, self.nz, self.n = sparsity, nz, n
        rows, cols = (np.asarray(i) for i in sparsity.get_triplet())
        self._where = (cols // nz, rows, cols % nz)  # (block, row, column) of each nonzero
        self.construct("eigen_clip", {})

    def get_n_in(self):
        """One input."""
        return 1

    def get_n_out(self):
        """One output."""
        return 1

    def get_sparsity_in(self, i):
        """The blocks' upper triangles."""
        return self.sparsity

    def get_sparsity_out(self, i):
        """Dense blocks."""
        return cs.Sparsity.dense(self.nz, self.nz * self.n)

    def has_eval_buffer(self):
        """Evaluate on the nonzeros' buffers (no copies through DM)."""
        return True

    def eval_buffer(self, arg, res):
        """Clip each block's eigenvalues."""
        upper = np.zeros((self.n, self.nz, self.nz))
        upper[self._where] = np.frombuffer(arg[0], dtype=float)
        values, vectors = np.linalg.eigh(upper, UPLO="U")
        clipped = (vectors * np.maximum(values, CLIP_MARGIN)[:, None]) @ \
            vectors.transpose(0, 2, 1)
        # Column-major (nz, N nz) output; the blocks are symmetric.
        np.frombuffer(res[0], dtype=float)[:] = clipped.ravel()
        return 0


@dataclass(frozen=True, eq=False)
class TrackingNLP:
    """The NLP of :func:`solve_tracking` with its derivative functions and bounds.

    Attributes:
        nlp: ``{"x", "f", "g"}`` MX expressions. x0, lbx, ubx, lbg, ubg: arrays.
        derivatives: nlpsol options ``hess_lag``, ``jac_g``, ``grad_f`` assembled from
            the stage functions.
        weights, params, smoothing: the cost weights, node parameters (NP, N) and the
            smoothing rows (A, b) (for the stage form,
            :mod:`~predgait.problems.fullbody_tracking_fatrop`).
        convex_derivatives: ``derivatives`` with each node's Hessian block
            eigen-clipped (:class:`EigenClip`, kept alive in ``clip``).
    """

    nlp: dict
    derivatives: dict
    x0: np.ndarray
    lbx: np.ndarray
    ubx: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray
    weights: np.ndarray | None = None
    params: np.ndarray | None = None
    smoothing: tuple | None = None
    convex_derivatives: dict | None = None
    clip: cs.Callback | None = None


def tracking_nlp(model: Model3D, data: TrackingData,
                 weights: TrackingWeights = TrackingWeights()) -> TrackingNLP:
    """The tracking NLP (module docstring), its derivatives from one node and one interval.

    Decision vector: node-major, z_k = (dx_k, v_k, a_k, f_k / FORCE_UNIT) (nz each).
    Constraints: ng per node, then NI per interval. The constraint Jacobian, the cost gradient and
    the Hessian of the Lagrangian are assembled from one node's and one interval's
    symbolic derivatives (:func:`stage_functions`), so the symbolic work does not grow
    with the number of nodes and no derivative is taken through the mapped calls.
    """
    n = data.nodes
    h = float(np.mean(np.diff(data.time)))
    stage = stage_functions(model, tuple(data.points))
    nz, ng, count = stage.nz, stage.ng, len(data.points)
    params = _node_parameters(data)
    w = _weight_vector(weights, model.total_mass() * model.gravity)
    x, no_p = cs.MX.sym("x", nz * n), cs.MX.sym("p", 0)
    z = cs.reshape(x, nz, n)
    qs = data.q.T
    g_node, cost = stage.node.map(n)(z, params, w)
    int_args = (z[:, :-1], z[:, 1:], qs[:, :-1], qs[:, 1:], h)
    g = cs.vertcat(cs.vec(g_node), cs.vec(stage.interval.map(n - 1)(*int_args)))
    jac_node = stage.node_jacobian.map(n)(z, params, w)
    grad_node = stage.node_gradient.map(n)(z, params, w)
    jac_int = stage.interval_jacobian.map(n - 1)(*int_args)
    jacobian = cs.vertcat(cs.diagcat(*cs.horzsplit(jac_node, nz)),
                          cs.diagcat(*cs.horzsplit(jac_int, 2 * nz)) @ _interval_columns(n, nz))
    # Hessian of the Lagrangian.
    sigma, lam = cs.MX.sym("sigma"), cs.MX.sym("lam", g.size1())
    lam_node = cs.reshape(lam[:ng * n], ng, n)
    lam_int = cs.reshape(lam[ng * n:], NI, n - 1)
    lam_pos, lam_rot = lam_int[64:67, :], lam_int[67:70, :]
    zero = cs.MX.zeros(3, 1)
    mu = -h / 2 * (cs.horzcat(lam_pos, zero) + cs.horzcat(zero, lam_pos))
    blocks = stage.node_hessian.map(n)(z, params, w, sigma / n, lam_node, mu)
    clip = EigenClip(blocks.sparsity(), nz, n)
    rblocks = stage.rotation_hessian.map(n - 1)(qs[:, :-1], qs[:, 1:], z[3:6, :-1],
                                                z[3:6, 1:], lam_rot)
    scatter = _scatter(n, nz)
    between = cs.triu(scatter.T @ cs.diagcat(*cs.horzsplit(rblocks, 6)) @ scatter)
    hessian = cs.diagcat(*cs.horzsplit(blocks, nz)) + between
    convex = cs.triu(cs.diagcat(*cs.horzsplit(clip(blocks), nz))) + between
    # Least-squares smoothing terms with a constant Hessian (fullbody_tracking_smooth).
    x0 = np.hstack([np.zeros((n, 35)), data.v, data.a,
                    _initial_forces(data) / FORCE_UNIT]).ravel()
    body_weight = model.total_mass() * model.gravity
    matrix, rhs = smoothing_terms(model, data, x0, nz, FORCE_UNIT, weights.torque_n_m,
                                  weights.acceleration_change_rad_s2,
                                  weights.force_change_bw * body_weight)
    residual = matrix @ x - rhs
    smooth = cs.sumsqr(residual)
    smooth_hessian = cs.triu(2 * matrix.T @ matrix)
    convex_hessian = cs.Function("nlp_hess_l", [x, no_p, sigma, lam],
                                 [convex + sigma * smooth_hessian],
                                 ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])
    derivatives = {
        "hess_lag": cs.Function("nlp_hess_l", [x, no_p, sigma, lam],
                                [hessian + sigma * smooth_hessian],
                                ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"]),
        "jac_g": cs.Function("nlp_jac_g", [x, no_p], [g, jacobian], ["x", "p"],
                             ["g", "jac_g_x"]),
        "grad_f": cs.Function("nlp_grad_f", [x, no_p],
                              [cs.sum2(cost) / n + smooth,
                               cs.vec(grad_node) / n + 2 * matrix.T @ residual],
                              ["x", "p"], ["f", "grad_f_x"])}
    # Bounds: contact heights, friction pyramid, no force off contact, fading contacts.
    on = data.contact.T.astype(bool)
    lbg_node, ubg_node = np.zeros((ng, n)), np.zeros((ng, n))
    ubg_node[6:6 + count] = np.where(on, 0.0, np.inf)
    lbg_node[6 + count:] = -np.inf
    lbx, ubx = np.full((n, nz), -np.inf), np.full((n, nz), np.inf)
    on_points = np.repeat(data.contact[:, :, None], 3, axis=2).reshape(n, 3 * count)
    lbx[:, 105:] = np.where(on_points, np.tile([-np.inf, -np.inf, 0.0], count), 0.0)
    ubx[:, 105:] = np.where(on_points, np.inf, 0.0)
    ubx[:, 107::3] = np.minimum(ubx[:, 107::3], fade_limits(data, body_weight) / FORCE_UNIT)
    x0 = np.minimum(x0, ubx.ravel())
    return TrackingNLP(
        {"x": x, "f": cs.sum2(cost) / n + smooth, "g": g}, derivatives, x0,
        lbx.ravel(), ubx.ravel(),
        np.concatenate([lbg_node.ravel(order="F"), np.zeros(NI * (n - 1))]),
        np.concatenate([ubg_node.ravel(order="F"), np.zeros(NI * (n - 1))]),
        w, params, (matrix, rhs), {**derivatives, "hess_lag": convex_hessian}, clip)


def solve_tracking(model: Model3D, data: TrackingData,
                   weights: TrackingWeights = TrackingWeights(), *,
                   max_iter: int = 200, tol: float = 1e-8,
                   print_level: int = 0, solver: str = "ipopt",
                   solver_options: dict | None = None,
                   convex_iterations: int = 0,
                   label: str = "whole-body tracking") -> TrackingSolution:
    """Solve the tracking problem (:func:`tracking_nlp`) with Ipopt.

    The exact Hessian (0 ``convex_iterations``, the default), or first
    ``convex_iterations`` iterations with each node's Hessian block eigen-clipped
    (:class:`EigenClip`: positive semi-definite, one factorisation an iteration), then
    the exact Hessian from that iterate (warm start: point, multipliers, barrier
    parameter) to ``tol``. The clipped start takes another path, which may end in
    another local optimum (subject01's cycle: the same optimum in 18 iterations instead
    of 89; walking5: another one, docs/DEVELOPING.md).
    ``label`` names the solve in the progress lines (:mod:`.ipopt_progress`).
    ``solver="fatrop"``: FATROP on the problem's stage form
    (:mod:`~predgait.problems.fullbody_tracking_fatrop`; no progress lines).
    ``solver_options``: more options of the solver (over the defaults here).

    Raises:
        SolveFailed: the solver did not converge (``best`` is the last iterate's solution).
    """
    start = time.perf_counter()
    n = data.nodes
    problem = tracking_nlp(model, data, weights)
    if solver == "fatrop":
        # FATROP's dual infeasibility stalls at 2e-7..4e-5 on subject01's cycle once at
        # Ipopt's optimum (relative 1e-7): its tolerance is at least 1e-6
        return _solve_fatrop(model, data, problem, start, max_iter, max(tol, 1e-6),
                             print_level, solver_options or {})
    ipopt = {"print_level": print_level, "sb": "yes", "max_iter": max_iter,
             "tol": tol, "constr_viol_tol": 1e-9,
             # monotone barrier from 0.1: the same optima, subject01's cycle
             # in 89 iterations (adaptive: 247, a first step raising mu to
             # ~2000 then crawling), walking5 in 90 (adaptive: 85), but its
             # 17-node stance in 87 (adaptive: 53; adaptive with mu_max 1:
             # cycle 111, stance 55, walking5 95 to another optimum,
             # objective 694.43 vs 702.32: not adopted)
             "mu_strategy": "monotone", "mu_init": 0.1,
             # METIS ordering: subject01's cycle, same 63 iterations, MUMPS
             # 20 -> 11 s CPU
             "mumps_pivot_order": 5, **(solver_options or {})}

    def ipopt_solver(name, derivatives, more):
        return cs.nlpsol(name, "ipopt", problem.nlp, {
            "print_time": False, **derivatives, "ipopt": {**ipopt, **more},
            **ipopt_progress.callback_options(name, problem.nlp["x"].numel(),
                                              problem.nlp["g"].numel())})

    convex = min(convex_iterations, max_iter)
    first = ipopt_solver("fullbody_tracking_convex" if convex else "fullbody_tracking",
                         problem.convex_derivatives if convex else problem.derivatives,
                         {"max_iter": convex} if convex else {})
    built = time.perf_counter()
    with one_blas_thread(), ipopt_progress.solving(label, problem.lbg, problem.ubg):
        # one BLAS thread: MUMPS' fronts are small, BLAS threads only cost here
        result = first(x0=problem.x0, lbx=problem.lbx, ubx=problem.ubx, lbg=problem.lbg,
                       ubg=problem.ubg)
    stats = first.stats()
    iterations = stats["iter_count"]
    if convex and not stats["success"] and max_iter > convex:
        # The exact Hessian from the first phase's iterate, multipliers and barrier.
        second = ipopt_solver("fullbody_tracking", problem.derivatives, {
            "max_iter": max_iter - convex, "mu_init": stats["iterations"]["mu"][-1],
            "warm_start_init_point": "yes", "warm_start_bound_push": 1e-9,
            "warm_start_slack_bound_push": 1e-9, "warm_start_mult_bound_push": 1e-9})
        with one_blas_thread(), ipopt_progress.solving(label, problem.lbg, problem.ubg):
            result = second(x0=result["x"], lam_x0=result["lam_x"], lam_g0=result["lam_g"],
                            lbx=problem.lbx, ubx=problem.ubx, lbg=problem.lbg,
                            ubg=problem.ubg)
        stats = second.stats()
        iterations += stats["iter_count"]
    seconds = time.perf_counter() - built
    solution = _unpack(model, data, np.asarray(result["x"]).reshape(n, -1),
                       {**stats, "iter_count": iterations}, seconds, built - start,
                       float(result["f"]))
    if not stats["success"]:
        raise SolveFailed(f"whole-body tracking did not converge: {stats['return_status']} "
                          f"after {iterations} iterations.", best=solution)
    return solution


def _solve_fatrop(model, data, problem, start, max_iter, tol, print_level, extra):
    """:func:`solve_tracking` with FATROP on the stage form of ``problem``."""
    from predgait.problems import fullbody_tracking_fatrop as stage_form

    nlp, options, bounds = stage_form.fatrop_nlp(model, problem, data, problem.weights,
                                                 problem.params, *problem.smoothing)
    extra = dict(extra)
    # CasADi's own options of its FATROP interface (the rest are FATROP's).
    options |= {k: extra.pop(k) for k in ("convexify_strategy", "convexify_margin")
                if k in extra}
    options |= {"print_time": False,
                "fatrop": {"print_level": print_level, "max_iter": max_iter, "tol": tol,
                           **extra}}
    solver = cs.nlpsol("fullbody_tracking_fatrop", "fatrop", nlp, options)
    built = time.perf_counter()
    with one_blas_thread():
        result = solver(**bounds)
    seconds = time.perf_counter() - built
    stats = solver.stats()
    layout = stage_form.StageLayout(len(data.points))
    z = stage_form.from_stage_vector(np.asarray(result["x"]), data.nodes, layout)
    solution = _unpack(model, data, z, stats, seconds, built - start, float(result["f"]))
    if not stats["success"]:
        raise SolveFailed(f"whole-body tracking (FATROP) did not converge: "
                          f"{stats['return_status']} after {stats['iter_count']} iterations.",
                          best=solution)
    return solution


def _unpack(model, data, z, stats, seconds, build_seconds, objective) -> TrackingSolution:
    dx, v, a = z[:, :35], z[:, 35:70], z[:, 70:105]
    f = FORCE_UNIT * z[:, 105:].reshape(z.shape[0], -1, 3)
    q = np.array([corrected_configuration(qr, d) for qr, d in zip(data.q, dx, strict=True)])
    return TrackingSolution(data.time.copy(), q, v.copy(), a.copy(), f.copy(),
                            contact_inverse_dynamics(model, q, v, a, f, data.points),
                            int(stats["iter_count"]), seconds, build_seconds,
                            str(stats["return_status"]), tuple(data.points), objective)


def point_positions(model: Model3D, q: np.ndarray, points: tuple[str, ...]) -> np.ndarray:
    """(N, P, 3) lab positions of the frames ``points`` at the configurations q (N, 36), m."""
    pm, pdata = model.pin_model, model.pin_model.createData()
    ids = [model.frame_id(p) for p in points]
    out = np.empty((q.shape[0], len(ids), 3))
    for k, row in enumerate(q):
        pin.framesForwardKinematics(pm, pdata, row)
        out[k] = [pdata.oMf[i].translation for i in ids]
    return out
