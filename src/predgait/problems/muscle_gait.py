"""Muscle-driven predictive gait of OpenSim's 2D_gait.osim by direct collocation (NLP).

The predictive problem of OpenSim Moco's ``example2DWalking`` (Dembia et al. 2020, PLoS
Comput Biol 16:e1008493), written with exact CasADi derivatives (Ipopt, exact Hessian):

* half a stride from right heel strike; periodicity with left/right symmetry as Moco's
  MocoPeriodicityGoal pairs it: every coordinate but pelvis_tx, every speed (pelvis_tx's
  with itself), the activations (left <-> right) and the lumbar control;
* average speed d / T = v_desired as a constraint (OpenSim 4.6's MocoAverageSpeedGoal
  is an endpoint constraint by default: Moco's log says "mode: endpoint_constraint"), or
  the cost w_speed (d / T - v_desired)^2 (its cost mode);
* cost = w_effort / d * integral sum_i |u_i|^3 dt (MocoControlGoal, weight 10, exponent 3,
  divided by displacement), over the 18 excitations and the lumbar control, with d the
  pelvis_tx displacement (the symmetric states put the centre of mass at the same height
  at both ends, so d is also Moco's centre-of-mass displacement) and T the free duration;
* optionally (the tracking stage that starts a prediction, as Moco's example starts
  from a MocoTrack solution) w_track times the mean squared coordinate error to a
  reference, rad^2 (m^2 for the pelvis translations).

Dynamics: implicit, :mod:`predgait.problems.muscle_gait_dynamics` (accelerations as
controls, the inverse-dynamics residual as constraints; Falisse et al. 2019): no symbolic
inverse of the 10x10 mass matrix, the residual is linear in the accelerations, so the
constraint Jacobian and the exact Hessian stay sparse.

Transcription (:class:`~predgait.problems.collocation.Transcription`): trapezoidal on N
uniform intervals of h = T/N (T free), the default,

    x_{k+1} - x_k - h/2 (xdot_k + xdot_{k+1}) = 0   for x = q (xdot = v), v (a), act, E,

or separated Hermite-Simpson (Moco's default; N intervals with their midpoints, 2N+1
points), with the residual and every bound at each point. Measured on this 2-core machine
(50 intervals, from referenceCoordinates.sto): trapezoidal builds in 14 s and converges in
87 iterations, 10 s (objective 0.134); Hermite-Simpson on the same mesh doubles the points
(build 75 s) and had not converged after 8 min of CPU. With implicit dynamics every
higher-order scheme adds points holding their own accelerations, residuals, muscle and
contact evaluations (HS 2N+1, Radau-3 3N+1), and the heel-strike transient of the stiff
sphere contacts (3 MN/m^1.5) is shorter than any affordable interval, so the order buys
little there; trapezoidal keeps every point one where the dynamics hold exactly, which
:func:`predgait.problems.muscle_gait_check.node_check` re-evaluates with Pinocchio.
Refining the trapezoidal grid to 100 intervals changed the objective by < 0.01 %
(0.13353 vs 0.13352) from Moco's solution as the guess.

Against Moco's own solution (OpenSim 4.6, Hermite-Simpson, 50 intervals, 274 iterations,
1955 s; objective 0.0219, half stride 0.400 s on its lower bound): our trapezoidal optimum
is 0.1335 (0.500 s), 6.1x higher, and stays there from Moco's solution as the guess, on 100
intervals (0.13353) and with the acceleration bound raised to 1e4 (0.13355, |a| <= 530).
Moco's trajectory satisfies this NLP's dynamics to a median 0.03 N (residual rows) but not
at the heel-strike impact (746 N at the third point of 101), and it does not hold the
example's activation periodicity (gap 0.99; tests/reference/osim2d/moco_prediction/
README.md): without those rows (``periodic_activations=False``) this NLP reaches 0.079 from
Moco's solution at 50 intervals; the rest of the gap goes with the impact transcription.

Decision vector (scaled; :meth:`MuscleGaitProblem.unpack` is the only place that slices
it): w = [h, vec(Q), vec(V), vec(A)/10, vec(ACT), vec(EXC), vec(U)/10, W/100, E/0.01], each
block (rows, N+1) column-major (node by node); h (1, N) is one step per interval, chained
equal, W the muscles' metabolic energy (J, W_0 = 0; the ``metabolic_weight`` term divides
it by distance and body mass) and E the running effort integral (E_0 = 0): the distance
q_tx(N), the duration N h_N and the effort E_N are last-point values, so no term couples
every node (a dense
row made MUMPS 4x slower: 0.35 s per factorisation at 50 intervals). Constraints:
residuals / 100, defects / h_0, periodicity, the average speed; box bounds on everything
(Moco's coordinate bounds).
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass

import casadi as cs
import numpy as np

from predgait.blas_threads import one_blas_thread
from predgait.errors import InputError
from predgait.problems import ipopt_progress
from predgait.problems.collocation import Solved, Transcription, _history
from predgait.problems.muscle_gait_dynamics import MusclePlant, node_function

#: Scale of each block of the decision vector (physical = scale * scaled).
SCALES = {"h": 0.01, "q": 1.0, "v": 1.0, "a": 10.0, "act": 1.0, "exc": 1.0, "u": 10.0,
          "ft": 1.0, "dft": 10.0, "W": 100.0, "E": 0.01}
NEVER_INLINE = False
#: The node outputs the objective and constraints use: residual, activation rate, contact
#: forces, metabolic rate, tendon equilibrium (:func:`node_function`'s outputs 0, 1, 2, 7, 8).
NODE_OUTPUTS_USED = (0, 1, 2, 7, 8)
#: Entries of the goal parameter vector (speed, 6 weights).
GOAL_SIZE = 7
#: Residual scale (N, N m per unit of the scaled constraint).
RESIDUAL_SCALE = 100.0
#: Nominal duration used to scale the defects, s.
NOMINAL_DURATION = 0.5
#: Ipopt's tolerances: Moco's example (convergence and constraint tolerance 1e-4).
IPOPT_OPTIONS = {"tol": 1e-4, "constr_viol_tol": 1e-4, "mu_strategy": "adaptive",
                 "linear_solver": "mumps", "hessian_approximation": "exact"}
#: Ipopt's warm start from a solved problem's primal-dual point (a muscle scenario's edited
#: model from its baseline: :mod:`predgait.scenarios.muscle_predict`). The pushes keep the
#: point 1e-3 inside its bounds (Ipopt's default 1e-3 for a cold start; 1e-9 kept the
#: baseline's active bounds and took 169 iterations on the weakness edit, 1e-3 took 37).
WARM_START = {"warm_start_init_point": "yes", "warm_start_bound_push": 1e-3,
              "warm_start_mult_bound_push": 1e-3, "warm_start_slack_bound_push": 1e-3}


@dataclass(frozen=True)
class Goal:
    """Objective weights and targets (see the module docstring)."""

    speed: float = 1.2            # m/s, desired average speed
    speed_constraint: bool = True  # OpenSim 4.6's MocoAverageSpeedGoal: endpoint constraint
    speed_weight: float = 0.0     # per (m/s)^2, when a cost (the goal's "cost" mode)
    effort_weight: float = 10.0   # per (unit control)^3 s / m
    tracking_weight: float = 0.0  # per rad^2 (m^2)
    acceleration_weight: float = 0.0  # per (rad/s^2)^2 s (Falisse et al. 2019's term)
    metabolic_weight: float = 0.0  # per J/kg/m of the muscles' metabolic energy (Bhargava)
    loading_rate_weight: float = 0.0  # per (BW/s)^2 s: each foot's vertical GRF rate squared


@dataclass(frozen=True)
class Bounds:
    """Box bounds (physical units): name -> (low, high) of every block.

    Attributes:
        q, v, a: (nq, 2) per coordinate (m, rad; /s; /s^2).
        duration: (low, high) s.
        activation, excitation: (low, high); lumbar: (low, high) control.
    """

    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    duration: tuple[float, float]
    activation: tuple[float, float]
    excitation: tuple[float, float]
    lumbar: tuple[float, float]
    tendon_force: tuple[float, float] = (0.0, 5.0)        # normalized (OpenSim's [0, 5])
    tendon_force_rate: tuple[float, float] = (-100.0, 100.0)   # 1/s


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A point of the NLP at the nodes (guess or solution), physical units.

    Attributes: duration (s); q, v, a (N+1, nq); act, exc (N+1, m); u (N+1,) lumbar;
    ft, dft (N+1, c) the compliant tendons' normalized forces and their rates (1/s), None
    when the muscles are rigid or the values are not known (a guess: :meth:`pack` takes the
    rigid-tendon forces).
    """

    duration: float
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    act: np.ndarray
    exc: np.ndarray
    u: np.ndarray
    ft: np.ndarray | None = None
    dft: np.ndarray | None = None

    @property
    def t(self) -> np.ndarray:
        """(N+1,) s from the first node."""
        return np.linspace(0.0, self.duration, self.q.shape[0])


@dataclass(frozen=True, eq=False)
class MuscleGait:
    """A solved half stride: the trajectory, forces and Ipopt's outcome.

    Attributes:
        path: the :class:`Trajectory`.
        grf: (N+1, n_spheres, 3) N, contact forces on the spheres (lab frame).
        points: (N+1, n_spheres, 3) m, where the contact forces act.
        force: (N+1, m) N, muscle-tendon forces. fibre: normalised fibre velocities.
        residual: (N+1, nq) N, N m, the NLP's own dynamics residual.
        muscle_tau: (N+1, nq) N m, the muscles' generalised forces.
        terms: unweighted objective terms; solved: status, iterations, time, history.
        tendon_residual: (N+1, c) the compliant tendons' equilibrium residuals (F_max units).
    """

    path: Trajectory
    grf: np.ndarray
    points: np.ndarray
    force: np.ndarray
    fibre: np.ndarray
    residual: np.ndarray
    muscle_tau: np.ndarray
    terms: dict
    objective: float
    solved: Solved
    tendon_residual: np.ndarray | None = None


def mirror_rows(names: tuple[str, ...]) -> np.ndarray:
    """Index i -> the row of the other side's ``names[i]`` (itself when unsided).

    Names ending in ``_r``/``_l`` pair (model coordinates ``hip_r``, OpenSim
    ``hip_flexion_r``, muscles ``soleus_r``).
    """
    out = []
    for name in names:
        side = name[-2:]
        other = name[:-2] + {"_r": "_l", "_l": "_r"}.get(side, side)
        out.append(names.index(other) if other in names else names.index(name))
    return np.array(out)


class MuscleGaitProblem:
    """The NLP of one grid; goal weights and the reference are parameters.

    Args:
        plant: the model, muscles and contacts (:class:`MusclePlant`).
        intervals: N.
        coordinate_names: model coordinates (for the left/right pairs).
        tx_row: model row of pelvis_tx (excluded from the position periodicity).
        max_iter: Ipopt's iteration limit.
        node: the node function (default :func:`node_function` of ``plant``; a scenario's
            adds its passive torques to the residual).
        residual_rows: coordinates whose dynamics residual rows are constraints (default
            all; a fused coordinate's row is the weld's reaction torque, left free).
        symmetric: the periodicity pairs left and right (a half stride); False: every row
            with itself (a whole stride, for a one-sided edit).
        ipopt_options: more Ipopt options (e.g. a warm start's).
        metabolic: the node function computes the muscles' metabolic rate (needed by a
            goal with ``metabolic_weight`` > 0; W stays 0 otherwise).
        periodic_activations: the activations are periodic (left <-> right) as the
            example's MocoPeriodicityGoal asks; False drops those rows (the problem Moco
            4.6 actually solved: its optimum's activations are not periodic, see
            tests/reference/osim2d/moco_prediction/README.md).
    """

    def __init__(self, plant: MusclePlant, mesh: int, *, tx_row: int,
                 transcription: Transcription = Transcription.TRAPEZOIDAL,
                 max_iter: int = 2000, print_level: int = 0,
                 node: cs.Function | None = None, residual_rows=None,
                 symmetric: bool = True, ipopt_options: dict | None = None,
                 periodic_activations: bool = True, metabolic: bool = False):
        if not 4 <= mesh <= 400:
            raise InputError(f"nodes = {mesh}: give 4..400 collocation intervals.")
        intervals = transcription.grid_intervals(mesh)     # grid steps (HS: + midpoints)
        self.plant, self.n, self.tx_row = plant, intervals, tx_row
        self.mesh, self.transcription = mesh, transcription
        nq, m, n1 = plant.model.nq, plant.n_muscles, intervals + 1
        self.sizes = (("h", 1, intervals), ("q", nq, n1), ("v", nq, n1), ("a", nq, n1),
                      ("act", m, n1), ("exc", m, n1), ("u", 1, n1),
                      ("ft", len(plant.compliant), n1), ("dft", len(plant.compliant), n1),
                      ("W", 1, n1), ("E", 1, n1))
        self.w = cs.SX.sym("w", sum(r * c for _, r, c in self.sizes))
        x = self.unpack(self.w)
        h, q, v, a, act, exc, u, ft, dft, energy, running = (
            x[k] for k in ("h", "q", "v", "a", "act", "exc", "u", "ft", "dft", "W", "E"))
        nc = len(plant.compliant)
        self.p_sizes = (("goal", GOAL_SIZE), ("q_ref", nq * n1))
        self.p = cs.SX.sym("p", GOAL_SIZE + nq * n1)
        goal, q_ref = self.p[:GOAL_SIZE], cs.reshape(self.p[GOAL_SIZE:], nq, n1)
        node = node_function(plant, metabolic) if node is None else node
        self.node, self.metabolic = node, metabolic
        # one call per node (not a map): MX differentiates each call through the node's
        # own symbolic SX derivatives, as fast as an SX graph and built in ~1 s
        tendon_in = (lambda k: [ft[:, k], dft[:, k]]) if nc else (lambda k: [])
        inputs = [[q[:, k], v[:, k], a[:, k], act[:, k], exc[:, k], u[:, k], *tendon_in(k)]
                  for k in range(n1)]
        calls = [node.call(args, False, NEVER_INLINE) for args in inputs]
        outputs = [cs.horzcat(*(c[i] for c in calls)) for i in range(9)]
        _, _, _, points, force, fibre, muscle_tau, _, _ = outputs
        # the outputs f and g use, as symbols (their derivatives: muscle_gait_derivatives)
        inlined = cs.vertcat(*(outputs[i] for i in NODE_OUTPUTS_USED))
        y = cs.SX.sym("y", inlined.shape[0], n1)
        r, act_dot, grf, metabolic_rate, tendon = cs.vertsplit(y, list(np.cumsum(
            [0, *(outputs[i].shape[0] for i in NODE_OUTPUTS_USED)])))
        scale = intervals / NOMINAL_DURATION       # 1 / h_0

        def defect(y, ydot):
            step = cs.repmat(h, y.shape[0], 1)
            if transcription is Transcription.TRAPEZOIDAL:
                return cs.vec(y[:, 1:] - y[:, :-1] - 0.5 * step * (ydot[:, 1:] + ydot[:, :-1]))
            # separated Hermite-Simpson: (a, m, b) = (2j, 2j+1, 2j+2), interval H = 2 h
            # (index lists: CasADi 3.8 slices a one-row matrix y[:, 0:-1:2] to y[0])
            first, middle, last = (list(range(k, intervals + k - 1, 2)) for k in (0, 1, 2))
            ya, ym, yb = y[:, first], y[:, middle], y[:, last]
            fa, fm, fb = ydot[:, first], ydot[:, middle], ydot[:, last]
            big = 2.0 * step[:, first]
            return cs.vertcat(cs.vec(ym - 0.5 * (ya + yb) - big / 8.0 * (fa - fb)),
                              cs.vec(yb - ya - big / 6.0 * (fa + 4.0 * fm + fb)))

        mq = mirror_rows(plant.model.coordinate_names)
        mm = mirror_rows(plant.muscle_names)
        if not symmetric:
            mq, mm = np.arange(nq), np.arange(m)
        # the compliant tendons' own left <-> right pairs (a symmetric set: see MusclePlant)
        mc = np.array([plant.compliant.index(int(mm[i])) for i in plant.compliant], int)
        rows = list(range(nq)) if residual_rows is None else list(residual_rows)
        keep = [i for i in range(nq) if i != tx_row]
        g = [cs.vec(r[rows, :]) / RESIDUAL_SCALE, cs.vec(tendon),
             defect(ft, dft) * scale / 10.0, (ft[:, -1] - ft[mc, 0]) if nc else cs.DM(0, 1),
             defect(q, v) * scale,
             defect(v, a) * scale / 10.0, defect(act, act_dot) * scale / 10.0,
             q[keep, -1] - q[mq[keep], 0], v[:, -1] - v[mq, 0],
             (act[:, -1] - act[mm, 0]) if periodic_activations else cs.DM(0, 1),
             u[:, -1] - u[:, 0],
             cs.vec(h[:, 1:] - h[:, :-1]) * scale,
             q[tx_row, -1] - goal[0] * intervals * h[0, -1],
             defect(energy, metabolic_rate) / SCALES["W"],
             defect(running, cs.sum1(exc ** 3) + cs.fabs(u) ** 3) / SCALES["E"]]
        self.ng = sum(e.shape[0] for e in g)
        self.speed_row = sum(e.shape[0] for e in g[:-3])    # distance - speed * duration
        quad = np.full((n1, 1), 1.0)
        quad[[0, -1]] = 0.5
        # pelvis_tx(0) = 0 (a bound) and E(0) = 0: the distance and the effort integral are
        # last-node values, so no objective term couples all nodes (a sparse KKT system)
        distance, duration = q[tx_row, -1], intervals * h[0, -1]
        tracking = cs.sum2(cs.sum1((q - q_ref) ** 2) @ quad) / intervals / nq
        # joint accelerations squared, trapezoidal in time (each interval's own step, so
        # the Hessian stays banded), mean over the joint coordinates
        joints = [i for i in range(nq) if i not in (0, 1, 2)]
        square = cs.sum1(a[joints, :] ** 2)
        acceleration = cs.sum2(h * 0.5 * (square[:, 1:] + square[:, :-1])) / len(joints)
        # each foot's vertical ground reaction rate squared, (BW/s)^2, summed over the
        # feet and integrated over the half stride (interval by interval: banded Hessian)
        weight = plant.model.total_mass() * plant.model.gravity
        loading = 0
        for side in ("_r", "_l"):
            spheres = [i for i, s in enumerate(plant.spheres) if s.link.endswith(side)]
            vertical = sum(grf[3 * i + 2, :] for i in spheres) / weight
            loading += cs.sum2((vertical[:, 1:] - vertical[:, :-1]) ** 2 / h)
        terms = {"speed": (distance / duration - goal[0]) ** 2,
                 "effort": running[0, -1] / distance,
                 "tracking": tracking,
                 "acceleration": acceleration,
                 "loading_rate": loading}
        objective = (goal[1] * terms["speed"] + goal[2] * terms["effort"]
                     + goal[3] * terms["tracking"] + goal[4] * terms["acceleration"]
                     + goal[6] * terms["loading_rate"])
        if self.metabolic:   # reported only when computed (W stays 0 otherwise)
            terms["metabolic"] = energy[0, -1] / distance / plant.model.total_mass()
            objective += goal[5] * terms["metabolic"]
        self.term_names = tuple(terms)
        g = cs.vertcat(*g)
        outer = cs.Function("outer", [self.w, self.p, y], [objective, g, r, grf, tendon,
                                                          *terms.values()])
        objective_w, g_w, r_w, grf_w, tendon_w, *terms_w = outer(self.w, self.p, inlined)
        self.outputs = cs.Function("outputs", [self.w, self.p],
                                   [r_w, grf_w, points, force, fibre, muscle_tau, *terms_w])
        self.tendon_residual = cs.Function("tendon_residual", [self.w], [tendon_w])
        self._derivatives = (self.w, self.p, cs.horzcat(*(cs.vertcat(*k) for k in inputs)),
                             y, objective, g)
        opts = {"ipopt": {"print_level": print_level, "sb": "yes", "max_iter": max_iter,
                          **IPOPT_OPTIONS, **(ipopt_options or {})}, "print_time": False}
        self.nlp = {"x": self.w, "p": self.p, "f": objective_w, "g": g_w}
        opts |= ipopt_progress.callback_options("muscle_gait", self.nlp["x"].numel(),
                                                self.nlp["g"].numel(), self.nlp["p"].numel())
        self._solver_options = opts

    @functools.cached_property
    def solver(self) -> cs.Function:
        """Ipopt on the NLP, built on first use.

        The exact derivatives come from :mod:`.muscle_gait_derivatives` (the node's
        derivatives derived once and mapped over the grid: ~1 s to build at 50 intervals,
        where CasADi's own of the inlined graph took ~20 s CPU); a stored solution
        (:mod:`predgait.problems.muscle_baseline_store`) is evaluated without it.
        """
        from predgait.problems.muscle_gait_derivatives import nlp_derivatives

        derivatives = nlp_derivatives(*self._derivatives, self.node, NODE_OUTPUTS_USED)
        return cs.nlpsol("muscle_gait", "ipopt", self.nlp, self._solver_options | derivatives)

    def build_solver(self) -> None:
        """Build :attr:`solver` now (on this thread) rather than at the first solve."""
        _ = self.solver

    def parameters(self, goal: Goal, reference: np.ndarray | None = None) -> np.ndarray:
        """The NLP's parameter vector: the goal (speed, 6 weights), then the reference."""
        n1, nq = self.n + 1, self.plant.model.nq
        ref = np.zeros((n1, nq)) if reference is None else np.asarray(reference, float)
        return np.concatenate([[goal.speed, goal.speed_weight, goal.effort_weight,
                                goal.tracking_weight, goal.acceleration_weight,
                                goal.metabolic_weight, goal.loading_rate_weight], ref.ravel()])

    def unpack(self, w) -> dict:
        """Block name -> (rows, N+1) physical values (symbolic or numeric)."""
        out, offset = {}, 0
        symbolic = isinstance(w, cs.SX | cs.MX)
        if not symbolic:
            w = np.asarray(w, dtype=float).ravel()
        for name, rows, cols in self.sizes:
            part = w[offset:offset + rows * cols] * SCALES[name]
            offset += rows * cols
            out[name] = (cs.reshape(part, rows, cols) if symbolic
                         else np.reshape(part, (cols, rows)).T)
        return out

    def pack(self, path: Trajectory) -> np.ndarray:
        """The scaled decision vector of a trajectory."""
        n = self.n
        def integral(f):
            return np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]))]) \
                * path.duration / n

        effort = (path.exc ** 3).sum(axis=1) + np.abs(path.u) ** 3
        ft, dft = self.tendon_guess(path)
        extra = [ft.T, dft.T] if ft.shape[1] else []
        rates = self.node.map(n + 1)(path.q.T, path.v.T, path.a.T, path.act.T, path.exc.T,
                                     np.reshape(path.u, (1, -1)), *extra)[7]
        blocks = {"h": np.full((1, n), path.duration / n), "q": path.q.T, "v": path.v.T,
                  "a": path.a.T, "act": path.act.T, "exc": path.exc.T,
                  "u": np.reshape(path.u, (1, -1)), "ft": ft.T, "dft": dft.T,
                  "W": integral(np.array(rates).ravel())[None, :],
                  "E": integral(effort)[None, :]}
        return np.concatenate([blocks[name].T.ravel() / SCALES[name]
                               for name, _, _ in self.sizes])

    def tendon_guess(self, path: Trajectory) -> tuple[np.ndarray, np.ndarray]:
        """(ft, dft) (N+1, c) of a trajectory: its own, or the rigid-tendon forces / F_max.

        Without its own values (a guess from coordinates, a rigid-tendon solution) the
        compliant tendons start at the force a rigid tendon would carry (clipped to
        [0, 5]) and its time derivative.
        """
        rows = list(self.plant.compliant)
        n1 = self.n + 1
        if not rows:
            return np.zeros((n1, 0)), np.zeros((n1, 0))
        if path.ft is not None and path.ft.shape == (n1, len(rows)):
            dft = path.dft if path.dft is not None else np.gradient(path.ft, path.t, axis=0)
            return path.ft, dft
        from predgait.problems.muscle_gait_dynamics import rigid_tendon_forces

        forces = np.array(rigid_tendon_forces(self.plant).map(n1)(
            path.q.T, path.v.T, path.act.T)).T[:, rows]
        fmax = np.array([self.plant.muscle_set.muscles[i].max_isometric_force for i in rows])
        ft = np.clip(forces / fmax, 0.0, 5.0)
        return ft, np.gradient(ft, path.t, axis=0)

    def box(self, bounds: Bounds) -> tuple[np.ndarray, np.ndarray]:
        """(lbx, ubx), scaled, with pelvis_tx fixed to 0 at the first node."""
        n1, m, c = self.n + 1, self.plant.n_muscles, len(self.plant.compliant)
        low = Trajectory(bounds.duration[0], *(np.tile(b[:, 0], (n1, 1))
                                               for b in (bounds.q, bounds.v, bounds.a)),
                         np.full((n1, m), bounds.activation[0]),
                         np.full((n1, m), bounds.excitation[0]),
                         np.full(n1, bounds.lumbar[0]),
                         np.full((n1, c), bounds.tendon_force[0]),
                         np.full((n1, c), bounds.tendon_force_rate[0]))
        high = Trajectory(bounds.duration[1], *(np.tile(b[:, 1], (n1, 1))
                                                for b in (bounds.q, bounds.v, bounds.a)),
                          np.full((n1, m), bounds.activation[1]),
                          np.full((n1, m), bounds.excitation[1]),
                          np.full(n1, bounds.lumbar[1]),
                          np.full((n1, c), bounds.tendon_force[1]),
                          np.full((n1, c), bounds.tendon_force_rate[1]))
        low.q[0, self.tx_row] = high.q[0, self.tx_row] = 0.0
        lbx, ubx = self.pack(low), self.pack(high)
        e = slice(lbx.size - n1, lbx.size)       # the effort integral: 0 at the start
        lbx[e], ubx[e] = 0.0, np.inf
        ubx[e.start] = 0.0
        w = slice(e.start - n1, e.start)         # the metabolic energy: 0 at the start
        lbx[w], ubx[w] = -np.inf, np.inf
        lbx[w.start] = ubx[w.start] = 0.0
        return lbx, ubx

    def solve(self, guess: Trajectory, bounds: Bounds, goal: Goal,
              reference: np.ndarray | None = None, *,
              label: str = "muscle-driven gait",
              multipliers: tuple[np.ndarray, np.ndarray] | None = None) -> MuscleGait:
        """Solve from ``guess``; ``reference`` (N+1, nq) for a tracking goal.

        ``label`` names the solve in the progress lines (:mod:`.ipopt_progress`).
        ``multipliers``: (lam_x, lam_g) of a problem of the same structure, for a problem
        built with :data:`WARM_START` (Ipopt then starts from the primal-dual point).
        """
        if goal.metabolic_weight > 0 and not self.metabolic:
            raise InputError("goal metabolic_weight > 0 on a problem built without the "
                             "metabolic rate: build it with metabolic=True.")
        p = self.parameters(goal, reference)
        lbx, ubx = self.box(bounds)
        w0 = np.clip(self.pack(guess), lbx, ubx)
        clock = time.perf_counter()
        lbg, ubg = np.zeros(self.ng), np.zeros(self.ng)
        if not goal.speed_constraint:
            lbg[self.speed_row], ubg[self.speed_row] = -np.inf, np.inf
        # one BLAS thread: MUMPS' small dense blocks gain nothing from threads on a shared
        # 2-core machine, and the iterates then do not depend on the process' thread count
        with one_blas_thread(), ipopt_progress.solving(label, lbg, ubg):
            start = ({} if multipliers is None else
                     {"lam_x0": multipliers[0], "lam_g0": multipliers[1]})
            out = self.solver(x0=w0, p=p, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, **start)
        seconds = time.perf_counter() - clock
        stats = self.solver.stats()
        g = np.clip(np.array(out["g"]).ravel(), lbg, ubg) - np.array(out["g"]).ravel()
        w = np.array(out["x"]).ravel()
        solved = Solved(w=w, status=stats["return_status"], success=bool(stats["success"]),
                        iterations=int(stats["iter_count"]), seconds=seconds,
                        objective=float(out["f"]),
                        constraint_violation=float(np.abs(g).max()),
                        history=_history(stats),
                        multipliers=(np.array(out["lam_x"]).ravel(),
                                     np.array(out["lam_g"]).ravel()))
        return self.evaluate(w, p, solved)

    def evaluate(self, w: np.ndarray, p: np.ndarray, solved: Solved) -> MuscleGait:
        """The gait of a (scaled) decision vector."""
        x = self.unpack(w)
        n1 = self.n + 1
        c = len(self.plant.compliant)
        path = Trajectory(float(x["h"].sum()), x["q"].T, x["v"].T, x["a"].T, x["act"].T,
                          x["exc"].T, x["u"].ravel(), x["ft"].T if c else None,
                          x["dft"].T if c else None)
        r, grf, points, force, fibre, muscle_tau, *terms = self.outputs(w, p)
        tendon = self.tendon_residual(w)
        k = len(self.plant.spheres)
        return MuscleGait(
            path=path, grf=np.array(grf).T.reshape(n1, k, 3),
            points=np.array(points).T.reshape(n1, k, 3), force=np.array(force).T,
            fibre=np.array(fibre).T, residual=np.array(r).T,
            muscle_tau=np.array(muscle_tau).T,
            tendon_residual=np.array(tendon).T.reshape(n1, c),
            terms={name: float(t) for name, t in zip(self.term_names, terms, strict=True)},
            objective=solved.objective, solved=solved)
