"""Predictive (and tracking) simulation of the planar 7-link model by direct collocation.

Optimal control of gait7 (:mod:`predgait.models.gait7`) walking on the smooth
Hunt-Crossley heel/toe contact with regularised friction
(:class:`predgait.dynamics.contact.HuntCrossleyContact`), after Ackermann & van den
Bogert (2010) J Biomech 43:1055-1060 (planar 7-segment model, effort per distance) and
OpenSim Moco's predictive 2D walking example (Dembia et al. 2020, PLoS Comput Biol
16:e1008493): a half gait cycle with left/right symmetry (or a full cycle), the
speed and the duration given.

Dynamics, implicit (inverse-dynamics residual): at every node k

    r_k = M(q_k) a_k + h(q_k, v_k) - sum_c J_c(q_k)^T F_c(q_k, v_k),
    r_k[base rows] = 0,   tau_k = r_k[joint rows] - tau_passive(q_k, v_k),

with M, h from ADAM on the same URDF as Pinocchio (:mod:`predgait.models.symbolic`) and
F_c the contact forces at heel_r, toe_r, heel_l, toe_l (planar: tangential X, normal Z).
The joint torques are then expressions, not variables. Implicit rather than forward
(ABA) dynamics: no symbolic inverse of the 9x9 mass matrix, the residual is linear in
the accelerations and polynomial-trigonometric in q, so the constraint Jacobian and the
exact Hessian are far sparser and better conditioned (van den Bogert et al. 2011,
Procedia IUTAM 2:297-316).

Transcription: trapezoidal on a uniform grid t_0..t_N of step h (O(h^2)):

    q_{k+1} - q_k - h/2 (v_k + v_{k+1}) = 0,   v_{k+1} - v_k - h/2 (a_k + a_{k+1}) = 0.

Trapezoidal rather than Hermite-Simpson: with implicit dynamics the latter needs
midpoint accelerations and residuals (twice the nodes for the same grid); the stance
transients of a stiff contact are shorter than any affordable interval, so the higher
order buys no accuracy there; and every node is then a point where the dynamics hold
exactly, which :func:`predgait.problems.predictive_check.node_residuals` re-evaluates
with Pinocchio.

Decision vector (the only place that slices it is :meth:`PredictiveProblem.unpack`):
w = [vec(Q), vec(V), vec(A)], each (nq, N+1) column-major (node by node).

Constraints: the residuals' base rows; the defects; periodicity
q_N = P q_0 + (d, 0, ..., 0), v_N = P v_0, with P the left/right swap of the joint
rows for a half cycle (identity for a full one) and d = speed * duration (so the
average speed is met exactly); contact points no deeper than ``max_penetration``;
joint ranges as bounds; base_x_0 fixed.

Objective (each term a mean over the cycle by the trapezoidal rule; the weights are
problem-file keys):

* tracking: mean squared error of base_pitch and the six joint angles, deg^2;
* grf: mean squared error of each foot's vertical force, in body weights^2;
* effort: integral of sum (tau_j / body mass)^2 dt over the distance walked,
  (N m/kg)^2 s/m (Ackermann & van den Bogert 2010 use a similar effort per distance);
* acceleration: mean squared joint acceleration, (rad/s^2)^2 (smoothness).
"""

from __future__ import annotations

import enum
import functools
import time
from dataclasses import dataclass, field

import casadi as cs
import numpy as np

from predgait.dynamics.contact import HuntCrossleyContact
from predgait.errors import InputError
from predgait.kinematics.clinical import clinical_joint
from predgait.models.gait7 import CONTACT_FRAMES
from predgait.models.loading import Model
from predgait.models.symbolic import symbolic_model
from predgait.problems import ipopt_progress
from predgait.problems.collocation import Solved, _history

#: Coordinates compared by the tracking term (the HAT height is left to the contact).
TRACKED = ("base_pitch", "hip_l", "knee_l", "ankle_l", "hip_r", "knee_r", "ankle_r")
JOINTS = ("hip_l", "knee_l", "ankle_l", "hip_r", "knee_r", "ankle_r")
#: Contact law of the predictive problems: body weight on one heel sinks it ~1.8 cm
#: (stiffer, 1e6, converges less reliably from the measured guess; Moco's 2D walking
#: example uses 3.07 MN/m^1.5 with 0.8 friction).
DEFAULT_CONTACT = HuntCrossleyContact(stiffness=3.0e5, exponent=1.5, dissipation=2.0,
                                      friction=0.8, slip_velocity_scale=0.05,
                                      smoothing=1.0e-4, damping_smoothing=1.0e-3)


#: Box bounds on the base (HAT) coordinates and on every rate and acceleration: far
#: outside walking (the bundled walk stays below 7.4 rad/s and 133 rad/s^2 at the
#: joints), they cut off the flailing solutions in which fast joint oscillations between
#: the nodes exploit the discretisation. name -> (q range, v range, a range), model units.
BASE_BOUNDS = {"base_x": ((-np.inf, np.inf), (-1.0, 5.0), (-30.0, 30.0)),
               "base_z": ((0.5, 1.3), (-1.0, 1.0), (-30.0, 30.0)),
               "base_pitch": ((-0.6, 0.6), (-3.0, 3.0), (-50.0, 50.0))}
#: Ipopt settings of the predictive problems.
IPOPT_OPTIONS = {"tol": 1e-6, "constr_viol_tol": 1e-6}


class Start(enum.Enum):
    """Where a solve starts, which sets Ipopt's barrier (:data:`BARRIER`).

    From a guess that does not solve the problem (the measured motion, or the unedited
    gait for an edited model), the monotone (Fiacco-McCormick) barrier converged where
    the adaptive one ended infeasible or ran out of iterations (measured guess, 40
    nodes; a right-ankle orthosis on a full cycle); from a solution of the problem with
    other weights, the adaptive barrier converged where the monotone one, restarting at
    mu = 0.1, wandered for 1000 iterations (bundled trial, 40-50 nodes). From a solution
    of the same problem on another grid, resampled, the monotone barrier from mu = 1e-4
    stays by it: 40 intervals onto 44 / 50 / 60 took 30 / 24 / 53 iterations (adaptive
    38 / 19 / 63, same optima), 20 onto 24 took 62 iterations to the same gait (2.1 deg),
    where the adaptive barrier ran out of 1000 iterations and the monotone one from
    mu = 0.1 found another gait (30 deg away). Which barrier converges also depends on
    the machine's floating-point kernels: a solve that fails is restarted with the others
    (``problems.predictive_solve.RESTARTS``).
    """

    MEASURED = "measured"
    SOLUTION = "solution"
    RESAMPLED = "resampled"


#: Ipopt's barrier settings for each :class:`Start`.
BARRIER = {Start.MEASURED: {"mu_strategy": "monotone"},
           Start.SOLUTION: {"mu_strategy": "adaptive"},
           Start.RESAMPLED: {"mu_strategy": "monotone", "mu_init": 1e-4}}


JOINT_RATE_BOUND = 15.0            # rad/s
JOINT_ACCELERATION_BOUND = 500.0   # rad/s^2


class Cycle(enum.Enum):
    """What one solution covers."""

    HALF = "half"    # right heel strike to left heel strike, left/right swap periodicity
    FULL = "full"    # a whole stride, plain periodicity (an asymmetric, edited model)


@dataclass(frozen=True)
class Weights:
    """Objective weights (see module docstring for units of each term)."""

    tracking: float = 0.0
    grf: float = 0.0
    effort: float = 1.0
    acceleration: float = 1e-4

    def vector(self) -> np.ndarray:
        """The weights in the order of the NLP parameter."""
        return np.array([self.tracking, self.grf, self.effort, self.acceleration])


@dataclass(frozen=True)
class PassiveSpring:
    """Linear spring-damper on a joint's clinical angle (an orthosis), thesis 3.3.1.

    Attributes: joint (gait7 name, e.g. "ankle_r"), k N m/rad, c N m s/rad, theta0 rad.
    """

    joint: str
    k: float
    c: float = 0.0
    theta0: float = 0.0


@dataclass(frozen=True)
class Reference:
    """Measured data at the nodes: q (N+1, nq) and each foot's vertical force (N+1, 2)."""

    q: np.ndarray
    foot_fz: np.ndarray


@dataclass(frozen=True)
class Guess:
    """Initial guess at the nodes: q, v, a (N+1, nq) each."""

    q: np.ndarray
    v: np.ndarray
    a: np.ndarray


@dataclass(frozen=True, eq=False)
class PredictedGait:
    """A solved cycle.

    Attributes:
        t: (N+1,) s from the start of the cycle.
        q, v, a: (N+1, nq) coordinates, velocities, accelerations (model units).
        tau: (N+1, 6) N m, active joint torques on JOINTS (model sign).
        contact: (N+1, 4, 2) N, (tangential X, normal Z) at CONTACT_FRAMES.
        terms: objective terms (unweighted) at the solution.
        solved: Ipopt's outcome (status, iterations, time, history).
        cycle, speed (m/s), duration (s).
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    tau: np.ndarray
    contact: np.ndarray
    terms: dict
    solved: Solved
    cycle: Cycle
    speed: float
    duration: float
    coordinate_names: tuple[str, ...] = field(default=())

    def foot_fz(self) -> np.ndarray:
        """(N+1, 2) N, vertical force of the right and the left foot (heel + toe)."""
        n = self.contact[:, :, 1]
        return np.column_stack([n[:, 0] + n[:, 1], n[:, 2] + n[:, 3]])


def mirror_matrix(model: Model, cycle: Cycle) -> np.ndarray:
    """(nq, nq) P of the periodicity: swaps left and right joint rows for a half cycle."""
    perm = np.eye(model.nq)
    if cycle is Cycle.FULL:
        return perm
    names = model.coordinate_names
    perm = np.zeros((model.nq, model.nq))
    for i, name in enumerate(names):
        other = name[:-1] + {"r": "l", "l": "r"}[name[-1]] if name[-2:] in ("_r", "_l") else name
        perm[i, names.index(other)] = 1.0
    return perm


@functools.lru_cache(maxsize=16)
def contact_dynamics(model: Model, contact: HuntCrossleyContact, ground_z: float
                     ) -> cs.Function:
    """``residual(q, v, a) -> (r, forces, heights)`` of gait7 on the ground (ADAM).

    r (nq,): M a + h - sum J^T F (N, N m); forces (8,): (F_x, F_z) of each contact frame,
    N; heights (4,): contact frames' z, m.
    """
    sym = symbolic_model(model)
    q, v, a = (cs.SX.sym(n, model.nq) for n in ("q", "v", "a"))
    applied, forces, heights = cs.SX.zeros(model.nq), [], []
    for frame in CONTACT_FRAMES:
        p = sym.frame_position(frame)(q)
        jac = cs.jacobian(p, q)
        vel = jac @ v
        normal, tangential = contact.force(ground_z - p[2], -vel[2], vel[0])
        applied += jac[0, :].T * tangential + jac[2, :].T * normal
        forces += [tangential, normal]
        heights.append(p[2])
    r = sym.mass_matrix(q) @ a + sym.bias_force(q, v) - applied
    return cs.Function("gait7_contact_residual", [q, v, a],
                       [r, cs.vertcat(*forces), cs.vertcat(*heights)],
                       ["q", "v", "a"], ["r", "forces", "heights"])


class PredictiveProblem:
    """The NLP of one grid (model, nodes, cycle, contact); solved for any data and weights.

    Reference, weights, duration, distance and spring parameters are NLP parameters and
    the joint ranges are bounds, so one built problem (cached by :func:`problem_for`)
    serves tracking and predictive solves, locks and orthoses without a rebuild.

    Args:
        model: gait7 (or an edited gait7).
        intervals: N, grid intervals.
        cycle: HALF or FULL.
        contact: The contact law. ground_z: floor height, m.
        max_penetration: deepest allowed contact point below the floor, m.
        max_iter: Ipopt iterations.
    """

    def __init__(self, model: Model, intervals: int, cycle: Cycle,
                 contact: HuntCrossleyContact = DEFAULT_CONTACT, ground_z: float = 0.0,
                 max_penetration: float = 0.03, max_iter: int = 1000):
        if not 4 <= intervals <= 400:
            raise InputError(f"nodes = {intervals}: give 4..400 collocation intervals.")
        self.model, self.n, self.cycle = model, intervals, cycle
        self.contact, self.ground_z = contact, ground_z
        nq, n1 = model.nq, intervals + 1
        self.joint_rows = [model.coordinate_index(j) for j in JOINTS]
        tracked = [model.coordinate_index(c) for c in TRACKED]
        self.w = cs.SX.sym("w", 3 * nq * n1)
        q, v, a = self.unpack(self.w)
        # parameters: weights (4), duration, distance, springs (3 per joint), q_ref, fz_ref
        self.p_sizes = (("weights", 4), ("duration", 1), ("distance", 1),
                        ("springs", 3 * len(JOINTS)), ("q_ref", nq * n1), ("fz_ref", 2 * n1))
        self.p = cs.SX.sym("p", sum(s for _, s in self.p_sizes))
        par, offset = {}, 0
        for name, size in self.p_sizes:
            par[name] = self.p[offset:offset + size]
            offset += size
        duration, distance = par["duration"], par["distance"]
        h = duration / intervals
        r, forces, heights = contact_dynamics(model, contact, ground_z).map(n1)(q, v, a)
        tau = r[self.joint_rows, :] - self._springs(q, v, par["springs"])
        mirror = mirror_matrix(model, cycle)
        shift = np.zeros(nq)
        shift[model.coordinate_index("base_x")] = 1.0
        g = [cs.vec(r[:3, :]),
             cs.vec(q[:, 1:] - q[:, :-1] - 0.5 * h * (v[:, 1:] + v[:, :-1])),
             cs.vec(v[:, 1:] - v[:, :-1] - 0.5 * h * (a[:, 1:] + a[:, :-1])),
             q[:, -1] - mirror @ q[:, 0] - shift * distance, v[:, -1] - mirror @ v[:, 0],
             cs.vec(heights)]
        n_eq = 3 * n1 + 2 * nq * intervals + 2 * nq
        self.lbg = np.concatenate([np.zeros(n_eq), np.full(4 * n1, ground_z - max_penetration)])
        self.ubg = np.concatenate([np.zeros(n_eq), np.full(4 * n1, np.inf)])
        quad = np.full((n1, 1), 1.0 / intervals)
        quad[[0, -1]] *= 0.5                      # trapezoidal mean over the cycle
        mass = model.total_mass()
        q_ref = cs.reshape(par["q_ref"], nq, n1)
        fz_ref = cs.reshape(par["fz_ref"], 2, n1)
        fz = cs.vertcat(forces[1, :] + forces[3, :], forces[5, :] + forces[7, :])
        weight = mass * model.gravity
        terms = {
            "tracking": cs.sum2(cs.sum1((q[tracked, :] - q_ref[tracked, :]) ** 2) @ quad)
            * (180 / np.pi) ** 2 / len(tracked),
            "grf": cs.sum2(cs.sum1(((fz - fz_ref) / weight) ** 2) @ quad) / 2,
            "effort": cs.sum2(cs.sum1((tau / mass) ** 2) @ quad) * duration / distance,
            "acceleration": cs.sum2(cs.sum1(a[self.joint_rows, :] ** 2) @ quad)
            / len(JOINTS),
        }
        weights = par["weights"]
        objective = sum(weights[i] * terms[k] for i, k in enumerate(terms))
        self.outputs = cs.Function("outputs", [self.w, self.p],
                                   [tau, forces, *terms.values()])
        self.term_names = tuple(terms)
        nlp = {"x": self.w, "p": self.p, "f": objective, "g": cs.vertcat(*g)}
        self._nlp, self._max_iter, self._solvers = nlp, max_iter, {}

    def solver(self, start: Start) -> cs.Function:
        """The Ipopt solver (exact Hessian) for solves from ``start`` (built once each)."""
        key = (start, ipopt_progress.active())
        if key not in self._solvers:
            nlp = self._nlp
            opts = {"ipopt": {"print_level": 0, "sb": "yes", "max_iter": self._max_iter,
                              "linear_solver": "mumps", "hessian_approximation": "exact",
                              **BARRIER[start], **IPOPT_OPTIONS},
                    "print_time": False,
                    **ipopt_progress.callback_options("gait7_predictive", nlp["x"].numel(),
                                                      nlp["g"].numel(), nlp["p"].numel())}
            self._solvers[key] = cs.nlpsol("gait7_predictive", "ipopt", nlp, opts)
        return self._solvers[key]

    def unpack(self, w):
        """(Q, V, A), each (nq, N+1), from a decision vector (symbolic or numeric)."""
        nq, n1 = self.model.nq, self.n + 1
        k = nq * n1
        if isinstance(w, cs.SX | cs.MX):
            return tuple(cs.reshape(w[i * k:(i + 1) * k], nq, n1) for i in range(3))
        w = np.asarray(w, dtype=float)
        return tuple(np.reshape(w[i * k:(i + 1) * k], (n1, nq)).T for i in range(3))

    def _springs(self, q, v, springs):
        """Generalised passive torques (6, N+1) on the joint rows: sign * M(angle, rate)."""
        rows = []
        for j, joint in enumerate(JOINTS):
            i = self.model.coordinate_index(joint)
            k, c, theta0 = springs[3 * j], springs[3 * j + 1], springs[3 * j + 2]
            rows.append(clinical_joint(self.model, joint).generalized_force(
                lambda angle, rate, k=k, c=c, theta0=theta0: -k * (angle - theta0) - c * rate,
                q[i, :], v[i, :]))
        return cs.vertcat(*rows)

    def spring_vector(self, springs) -> np.ndarray:
        """NLP parameter of the passive springs (3 per joint; zero where none)."""
        out = np.zeros(3 * len(JOINTS))
        for s in springs:
            if s.joint not in JOINTS:
                raise InputError(f"passive element on '{s.joint}': give one of "
                                 f"{', '.join(JOINTS)}.")
            j = JOINTS.index(s.joint)
            out[3 * j:3 * j + 3] += (s.k, s.c, s.theta0 * (s.k > 0))
        return out

    def box_bounds(self, bounds: dict[str, tuple[float, float]]):
        """([q_lo, v_lo, a_lo], [q_hi, v_hi, a_hi]), each (N+1, nq).

        BASE_BOUNDS, the joint rate and acceleration bounds, and ``bounds`` (coordinate
        -> q range).
        """
        n1, nq = self.n + 1, self.model.nq
        lo = [np.full((n1, nq), -np.inf), np.full((n1, nq), -JOINT_RATE_BOUND),
              np.full((n1, nq), -JOINT_ACCELERATION_BOUND)]
        hi = [-b for b in lo]
        hi[0] = np.full((n1, nq), np.inf)
        for name, ranges in BASE_BOUNDS.items():
            i = self.model.coordinate_index(name)
            for k, (low, high) in enumerate(ranges):
                lo[k][:, i], hi[k][:, i] = low, high
        for name, (low, high) in bounds.items():
            i = self.model.coordinate_index(name)
            lo[0][:, i], hi[0][:, i] = low, high
        return lo, hi

    def solve(self, guess: Guess, reference: Reference, weights: Weights, *, speed: float,
              duration: float, bounds: dict[str, tuple[float, float]],
              springs=(), start: Start = Start.MEASURED,
              label: str = "predictive gait") -> PredictedGait:
        """Solve from ``guess``; ``bounds``: coordinate -> (lower, upper) (model units).

        ``start``: whether ``guess`` is measured or a solution (see :class:`Start`);
        ``label`` names the solve in the progress lines (:mod:`.ipopt_progress`).
        """
        n1 = self.n + 1
        params = {"weights": weights.vector(), "duration": [duration],
                  "distance": [speed * duration], "springs": self.spring_vector(springs),
                  "q_ref": reference.q.ravel(), "fz_ref": reference.foot_fz.ravel()}
        p = np.concatenate([np.asarray(params[name], dtype=float).ravel()
                            for name, _ in self.p_sizes])
        lo, hi = self.box_bounds(bounds)
        x = self.model.coordinate_index("base_x")
        lo[0][0, x] = hi[0][0, x] = guess.q[0, x]
        lbx = np.concatenate([b.ravel() for b in lo])
        ubx = np.concatenate([b.ravel() for b in hi])
        w0 = np.concatenate([guess.q.ravel(), guess.v.ravel(), guess.a.ravel()])
        w0 = np.clip(w0, lbx, ubx)
        solver = self.solver(start)
        clock = time.perf_counter()
        with ipopt_progress.solving(label, self.lbg, self.ubg):
            out = solver(x0=w0, p=p, lbx=lbx, ubx=ubx, lbg=self.lbg, ubg=self.ubg)
        seconds = time.perf_counter() - clock
        stats = solver.stats()
        g = np.array(out["g"]).ravel()
        violation = np.maximum(np.maximum(self.lbg - g, g - self.ubg), 0.0)
        w = np.array(out["x"]).ravel()
        solved = Solved(w=w, status=stats["return_status"], success=bool(stats["success"]),
                        iterations=int(stats["iter_count"]), seconds=seconds,
                        objective=float(out["f"]),
                        constraint_violation=float(violation.max()),
                        history=_history(stats))
        q, v, a = self.unpack(w)
        tau, forces, *terms = self.outputs(w, p)
        return PredictedGait(
            t=np.linspace(0.0, duration, n1), q=q.T, v=v.T, a=a.T, tau=np.array(tau).T,
            contact=np.array(forces).T.reshape(n1, 4, 2),
            terms={k: float(t) for k, t in zip(self.term_names, terms, strict=True)},
            solved=solved, cycle=self.cycle, speed=speed, duration=duration,
            coordinate_names=tuple(self.model.coordinate_names))


@functools.lru_cache(maxsize=8)
def problem_for(model: Model, intervals: int, cycle: Cycle,
                contact: HuntCrossleyContact = DEFAULT_CONTACT, ground_z: float = 0.0,
                max_penetration: float = 0.03, max_iter: int = 1000) -> PredictiveProblem:
    """The (cached) problem of these settings: built once, solved many times."""
    return PredictiveProblem(model, intervals, cycle, contact, ground_z, max_penetration,
                             max_iter)
