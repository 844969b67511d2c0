"""Trapezoidal direct collocation of the leg with the foot prescribed (CasADi + Ipopt).

Dynamics (symbolic, ADAM on the same URDF as Pinocchio): with the base (foot)
coordinates q_b prescribed and the free joints q_f = (ankle, knee),

    M_ff(q) a_f = tau_f + (J_H^T w_H)_f - h_f(q, v) - M_fb(q) a_b,

where w_H = (F_x, F_z, M_y) is the hip load at ``hip_center`` and J_H the Jacobian of
(hip x, hip z, thigh pitch), built from the numeric engine's description of the leg
(:func:`free_dynamics`); Pinocchio's :class:`predgait.dynamics.forward.LegSystem`
checks every result.

Decision vector layout (opty-style, documented once; :meth:`LegCollocation.unpack` is the
only place that slices it):

    w = [ x_0, x_1, ..., x_N, p ]   with x_k = (q_ankle, q_knee, v_ankle, v_knee) at node k
                                    (rad, rad/s) and p the problem's own parameters.

Defects on the grid t_0..t_N of step h (:class:`Transcription`):

* trapezoidal: x_{k+1} - x_k - h/2 (f_k + f_{k+1}) = 0 for k = 0..N-1 (error O(h^2));
* Hermite-Simpson (separated form; N even, the odd points are the interval midpoints,
  intervals of length H = 2h): for each interval (a, m, b) = (2j, 2j+1, 2j+2)
  x_m - (x_a + x_b)/2 - H/8 (f_a - f_b) = 0 and x_b - x_a - H/6 (f_a + 4 f_m + f_b) = 0
  (error O(H^4)). Inputs (torque changes) live on every grid point, midpoints included.

The initial
state is fixed to the measured one: the optimised trajectory is then the forward
simulation of the optimised inputs (a simulation-based fit, as in the thesis' question
"which inputs keep the synthesized motion near the measured one").
"""

from __future__ import annotations

import enum
import functools
import time
from dataclasses import dataclass, field

import casadi as cs
import numpy as np

from predgait.dynamics.drivers import LegDrivers
from predgait.dynamics.forward import LEG_FREE
from predgait.dynamics.partitioned import free_accelerations
from predgait.errors import InputError
from predgait.kinematics.clinical import clinical_joint
from predgait.models.loading import Model
from predgait.models.symbolic import symbolic_model
from predgait.problems import solver_cache

N_STATES = 4


class Transcription(enum.Enum):
    """How the dynamics are discretised between grid points."""

    TRAPEZOIDAL = "trapezoidal"
    HERMITE_SIMPSON = "hermite_simpson"

    def grid_intervals(self, intervals: int) -> int:
        """Grid steps for ``intervals`` collocation intervals (HS adds the midpoints)."""
        return 2 * intervals if self is Transcription.HERMITE_SIMPSON else intervals


@functools.lru_cache(maxsize=8)
def free_dynamics(model: Model) -> cs.Function:
    """``free_dynamics(x, qb, vb, ab, tau, hip) -> xdot`` for the leg with the foot prescribed.

    x: (4,) free state; qb, vb, ab: (3,) base coordinates, rates, accelerations;
    tau: (2,) ankle, knee torques (model sign, N m); hip: (3,) F_x, F_z (N), M_y (N m).

    Built from the numeric engine's description of the leg
    (:class:`predgait.dynamics.forward.LegSystem`): the same free rows (``LEG_FREE``),
    joint torques on those rows, the hip load at frame ``hip_center`` (force through its
    position Jacobian, moment on the thigh's rows of the joint-sign table) and the same
    partitioned equations (:func:`predgait.dynamics.partitioned.free_accelerations`), on
    ADAM's M and h of the same URDF.
    """
    sym = symbolic_model(model)
    free = [model.coordinate_index(n) for n in LEG_FREE]
    pres = [i for i in range(model.nq) if i not in free]
    x, qb, vb, ab = cs.SX.sym("x", 4), cs.SX.sym("qb", 3), cs.SX.sym("vb", 3), cs.SX.sym("ab", 3)
    tau, hip = cs.SX.sym("tau", 2), cs.SX.sym("hip", 3)
    q, v = cs.SX.zeros(model.nq), cs.SX.zeros(model.nq)
    q[pres], q[free], v[pres], v[free] = qb, x[:2], vb, x[2:]
    point = sym.frame_position("hip_center")(q)
    thigh = clinical_joint(model, "hip").coordinates  # rows turning the thigh about +Y
    pitch = sum(q[model.coordinate_index(c)] for c in thigh)
    applied = cs.SX.zeros(model.nq)
    applied[free] = tau
    applied += cs.jacobian(cs.vertcat(point[0], point[2], pitch), q).T @ hip
    accel = free_accelerations(sym.mass_matrix(q), sym.bias_force(q, v), applied, ab,
                               free, pres)
    return cs.Function("free_dynamics", [x, qb, vb, ab, tau, hip], [cs.vertcat(x[2:], accel)],
                       ["x", "qb", "vb", "ab", "tau", "hip"], ["xdot"])


@dataclass(frozen=True)
class NodeData:
    """Measured inputs and reference at the collocation nodes (arrays with N+1 rows).

    ``x_ref`` (N+1, 4) is the motion to track (and its first row the initial state);
    ``feedback_ref`` (N+1, 4), when given, is the reference of the PD feedback law
    (default: ``x_ref``), so gains can be identified from a measured closed-loop response.
    """

    t: np.ndarray
    qb: np.ndarray
    vb: np.ndarray
    ab: np.ndarray
    tau: np.ndarray
    hip: np.ndarray
    x_ref: np.ndarray
    feedback_ref: np.ndarray | None = None

    @classmethod
    def from_drivers(cls, drivers: LegDrivers, t0: float, t1: float, n: int) -> NodeData:
        """Sample the drivers (the forward simulation's own splines) on n intervals."""
        if drivers.time_range is not None:
            lo, hi = drivers.time_range
            if t0 < lo - 1e-9 or t1 > hi + 1e-9 or t1 <= t0:
                raise InputError(f"window {t0:g}..{t1:g} s lies outside the trial "
                                 f"{lo:.3f}..{hi:.3f} s (time from heel strike).")
        if not 10 <= n <= 2000:
            raise InputError(f"nodes = {n}: give 10..2000 collocation intervals.")
        t = np.linspace(t0, t1, n + 1)

        def sample(function):
            return np.array([function(tk) for tk in t])

        hip_force, hip_moment = sample(drivers.hip_force), sample(drivers.hip_moment)
        q_ref, qd_ref = sample(drivers.reference_q), sample(drivers.reference_qd)
        return cls(t=t, qb=sample(drivers.prescribed_q), vb=sample(drivers.prescribed_qd),
                   ab=sample(drivers.prescribed_qdd), tau=sample(drivers.joint_torque),
                   hip=np.column_stack([hip_force[:, 0], hip_force[:, 2], hip_moment[:, 1]]),
                   x_ref=np.column_stack([q_ref[:, 3:], qd_ref[:, 3:]]))


@dataclass(frozen=True)
class Solved:
    """Raw outcome of one Ipopt solve.

    ``history``: per Ipopt iteration (iteration 0 = the start) ``objective``,
    ``constraint_violation`` (inf_pr) and ``dual_infeasibility`` (inf_du).
    ``multipliers``: Ipopt's (lam_x, lam_g) at the end, when the problem keeps them (a
    warm start of a similar problem begins from them).
    """

    w: np.ndarray
    status: str
    success: bool
    iterations: int
    seconds: float
    objective: float
    constraint_violation: float
    history: dict = field(default_factory=dict)
    multipliers: tuple[np.ndarray, np.ndarray] | None = None


class LegCollocation:
    """Trapezoidal collocation on a fixed grid; problems add parameters and objectives.

    The measured node data enter the NLP as CasADi parameters, so a problem built once
    (cached by the problems for a model, grid size and step) is solved again on other
    data or windows of the same length without rebuilding the solver.

    Args:
        model: The leg.
        n: Number of grid steps (even for Hermite-Simpson: 2 per interval).
        h: Grid step, s.
        n_params: Number of problem parameters appended to w.
        transcription: Trapezoidal or Hermite-Simpson defects.
    """

    #: Symbol type of the NLP: ``solver_cache.symbol_type()``. MX keeps the mapped node
    #: dynamics one call node: ~4-10x faster to build than SX (which inlines every node),
    #: slower to solve in CasADi's virtual machine, so MX problems are compiled and cached
    #: on disk (:mod:`predgait.problems.solver_cache`); with the cache off, SX.

    #: Node data as NLP parameters: name -> rows per node (qb, vb, ab, tau, hip, x_ref).
    DATA = (("qb", 3), ("vb", 3), ("ab", 3), ("tau", 2), ("hip", 3), ("x_ref", 4),
            ("feedback_ref", 4))

    def __init__(self, model: Model, n: int, h: float, n_params: int,
                 transcription: Transcription = Transcription.TRAPEZOIDAL):
        if transcription is Transcription.HERMITE_SIMPSON and n % 2:
            raise InputError(f"Hermite-Simpson needs an even number of grid steps, not {n}.")
        self.model, self.n, self.h, self.n_params = model, n, h, n_params
        self.transcription = transcription
        sym = solver_cache.symbol_type()
        self.w = sym.sym("w", N_STATES * (n + 1) + n_params)
        self.x, self.p = self.unpack(self.w)
        rows = sum(r for _, r in self.DATA)
        self.data = sym.sym("data", rows, n + 1)
        offset, self.node = 0, {}
        for name, r in self.DATA:
            self.node[name] = self.data[offset:offset + r, :]
            offset += r
        self.f = free_dynamics(model)

    def data_values(self, nodes: NodeData) -> np.ndarray:
        """Numeric value of the NLP parameter for these nodes (column-major)."""
        if len(nodes.t) != self.n + 1 or abs(nodes.t[1] - nodes.t[0] - self.h) > 1e-12:
            raise InputError("node data do not match the problem's grid.")
        values = {name: getattr(nodes, name) for name, _ in self.DATA}
        if values["feedback_ref"] is None:
            values["feedback_ref"] = nodes.x_ref
        stacked = np.column_stack([values[name] for name, _ in self.DATA]).T
        return stacked.ravel(order="F")

    def unpack(self, w):
        """(X (4, N+1), p (n_params,)) from a decision vector (symbolic or numeric)."""
        k = N_STATES * (self.n + 1)
        x = cs.reshape(w[:k], N_STATES, self.n + 1) if isinstance(w, cs.SX | cs.MX) else \
            np.reshape(np.asarray(w)[:k], (self.n + 1, N_STATES)).T
        return x, w[k:]

    def xdot(self, tau_extra, passive_knee=None, feedback=None):
        """State derivatives (4, N+1) at the nodes.

        Args:
            tau_extra: Torques (2, N+1) added to the measured ones, N m (model sign).
            passive_knee: Optional function (q_knee, v_knee) -> model knee torque.
            feedback: Optional feedback torques (2, N+1), N m.
        """
        node = self.node
        tau = node["tau"] + tau_extra
        if passive_knee is not None:
            tau = cs.vertcat(tau[0, :], tau[1, :] + passive_knee(self.x[1, :], self.x[3, :]))
        if feedback is not None:
            tau = tau + feedback
        f_map = self.f.map(self.n + 1)
        return f_map(self.x, node["qb"], node["vb"], node["ab"], tau, node["hip"])

    def defects(self, xdot, x0=None) -> cs.SX:
        """Collocation defects (4 N,) and the initial state (4,) fixed to ``x0``.

        ``x0`` defaults to the measured initial state.
        """
        x = self.x
        if self.transcription is Transcription.HERMITE_SIMPSON:
            big = 2 * self.h
            xa, xm, xb = x[:, 0:-1:2], x[:, 1::2], x[:, 2::2]
            fa, fm, fb = xdot[:, 0:-1:2], xdot[:, 1::2], xdot[:, 2::2]
            d = cs.vertcat(xm - 0.5 * (xa + xb) - big / 8 * (fa - fb),
                           xb - xa - big / 6 * (fa + 4 * fm + fb))
        else:
            d = x[:, 1:] - x[:, :-1] - 0.5 * self.h * (xdot[:, 1:] + xdot[:, :-1])
        start = self.node["x_ref"][:, 0] if x0 is None else x0
        return cs.vertcat(cs.vec(d), x[:, 0] - start)

    def tracking(self) -> cs.SX:
        """Mean squared angle error over the nodes, rad^2."""
        err = self.x[:2, :] - self.node["x_ref"][:2, :]
        return cs.sumsqr(err) / (2 * (self.n + 1))

    def build(self, objective, constraints, *, max_iter: int = 200):
        """The Ipopt solver (exact Hessian) of this problem."""
        nlp = {"x": self.w, "p": cs.vec(self.data), "f": objective, "g": constraints}
        opts = {"ipopt": {"print_level": 0, "sb": "yes", "max_iter": max_iter, "tol": 1e-8,
                          "linear_solver": "mumps", "hessian_approximation": "exact"},
                "print_time": False}
        return solver_cache.ipopt_solver("leg_collocation", nlp, opts)

    def solve(self, solver, nodes: NodeData, *, p0, p_bounds) -> Solved:
        """Solve on ``nodes``, warm-started from the measured motion."""
        w0 = np.concatenate([nodes.x_ref.ravel(), np.asarray(p0, dtype=float)])
        lo = np.concatenate([np.full(N_STATES * (self.n + 1), -np.inf), p_bounds[0]])
        hi = np.concatenate([np.full(N_STATES * (self.n + 1), np.inf), p_bounds[1]])
        guess = w0[N_STATES * (self.n + 1):]
        if np.any(guess < lo[N_STATES * (self.n + 1):]) or \
                np.any(guess > hi[N_STATES * (self.n + 1):]):
            raise InputError("the initial guess of a parameter lies outside its bounds.")
        start = time.perf_counter()
        out = solver(x0=w0, p=self.data_values(nodes), lbx=lo, ubx=hi, lbg=0, ubg=0)
        seconds = time.perf_counter() - start
        stats = solver.stats()
        g = np.array(out["g"]).ravel()
        return Solved(w=np.array(out["x"]).ravel(), status=stats["return_status"],
                      success=bool(stats["success"]), iterations=int(stats["iter_count"]),
                      seconds=seconds, objective=float(out["f"]),
                      constraint_violation=float(np.abs(g).max()) if g.size else 0.0,
                      history=_history(stats))


def _history(stats: dict) -> dict:
    """Objective and infeasibilities per Ipopt iteration, from the solver statistics."""
    its = stats.get("iterations") or {}
    names = (("objective", "obj"), ("constraint_violation", "inf_pr"),
             ("dual_infeasibility", "inf_du"))
    return {name: [float(v) for v in its.get(key, ())] for name, key in names}
