"""The three optimisation problems of the leg, on :class:`LegCollocation`.

* Knee spring/damper fit: k (N m/rad), c (N m s/rad), theta0 (rad) of a linear passive
  knee element (thesis eqs. 3.3.1-3.3.2) added to the measured moments, such that the
  synthesized motion stays nearest the measured one. 95 % confidence intervals from the
  Gauss-Newton covariance sigma^2 (J^T J)^-1, with J the sensitivity of the angle
  residuals to the parameters along the dynamics (dX/dp = -G_X^-1 G_p).
* Torque correction: the smallest smooth changes dtau(t) (N m, model sign) of the ankle
  and knee moments such that the synthesized motion tracks the measured one.
* Feedback gains: PD gains kp (N m/rad), kd (N m s/rad) per joint on the tracking error
  that bring a perturbed start back onto the measured motion under the uncorrected
  moments (the thesis' future work: control).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as cs
import numpy as np

from predgait.dynamics.passive import LinearSpringDamper
from predgait.errors import SolveFailed
from predgait.problems.collocation import LegCollocation, NodeData, Solved


@dataclass(frozen=True)
class FitResult:
    """What a problem found, with its solver outcome.

    Attributes:
        kind: ``knee_fit``, ``torque_correction`` or ``feedback_gains``.
        parameters: name -> value (SI).
        confidence95: name -> half-width of the 95 % interval (where computed).
        t: (N+1,) node times, s.
        x: (N+1, 4) optimised free states (ankle, knee, rates; model coordinates).
        torque_change: (N+1, 2) N m added to the measured moments (torque correction).
        solved: Ipopt outcome.
        rms_deg: RMS angle error (ankle, knee) of the optimised motion vs measured, deg.
    """

    kind: str
    parameters: dict
    confidence95: dict
    t: np.ndarray
    x: np.ndarray
    torque_change: np.ndarray | None
    solved: Solved
    rms_deg: dict = field(default_factory=dict)


def _knee_passive(params):
    """Model knee torque of the linear element on clinical flexion = -q_knee."""
    element = LinearSpringDamper(k=params[0], c=params[1], theta0=params[2])
    return lambda q, v: -element.moment(-q, -v)


def _check(solved: Solved, kind: str) -> None:
    if not solved.success:
        raise SolveFailed(f"{kind}: Ipopt stopped with '{solved.status}' after "
                          f"{solved.iterations} iterations (objective {solved.objective:.4g}, "
                          f"constraint violation {solved.constraint_violation:.2e}); no "
                          "result is reported. Try a shorter window, more nodes or other "
                          "bounds.", best=solved)


def _rms(col: LegCollocation, w) -> dict:
    x, _ = col.unpack(w)
    err = np.degrees(x[:2, :].T - col.nodes.x_ref[:, :2])
    return {"ankle": float(np.sqrt(np.mean(err[:, 0] ** 2))),
            "knee": float(np.sqrt(np.mean(err[:, 1] ** 2)))}


def _confidence(col: LegCollocation, constraints, residuals, w, names) -> dict:
    """95 % half-widths of the parameters by Gauss-Newton along the dynamics."""
    xs = col.w[: -col.n_params]
    g_x = cs.Function("gx", [col.w], [cs.jacobian(constraints, xs)])(w)
    g_p = cs.Function("gp", [col.w], [cs.jacobian(constraints, col.p)])(w)
    r_x = cs.Function("rx", [col.w], [cs.jacobian(residuals, xs)])(w)
    r = np.array(cs.Function("r", [col.w], [residuals])(w)).ravel()
    sens = -np.linalg.solve(np.array(g_x), np.array(g_p))
    jac = np.array(r_x) @ sens
    dof = max(r.size - len(names), 1)
    sigma2 = float(r @ r) / dof
    cov = sigma2 * np.linalg.pinv(jac.T @ jac)
    return {n: float(1.96 * np.sqrt(max(cov[i, i], 0.0))) for i, n in enumerate(names)}


def fit_knee(model, nodes: NodeData, *, k0: float = 10.0, c0: float = 1.0,
             k_max: float = 2000.0, c_max: float = 200.0, fit_theta0: bool = True,
             max_iter: int = 200) -> FitResult:
    """Fit k, c (and theta0) of the knee so that the synthesized motion tracks the measured."""
    col = LegCollocation(model, nodes, 3)
    residuals = cs.vec(col.x[:2, :] - nodes.x_ref[:, :2].T)
    constraints = col.defects(col.xdot(0, passive_knee=_knee_passive(col.p)))
    theta_lim = np.radians(60.0) if fit_theta0 else 0.0
    solved = col.solve(col.tracking(), constraints, p0=[k0, c0, 0.0],
                       p_bounds=([0.0, 0.0, -theta_lim], [k_max, c_max, theta_lim]),
                       max_iter=max_iter)
    _check(solved, "knee fit")
    _, p = col.unpack(solved.w)
    names = ["k", "c", "theta0"] if fit_theta0 else ["k", "c"]
    ci = _confidence(col, constraints, residuals, solved.w, names) if fit_theta0 else \
        _confidence(col, constraints, residuals, solved.w, ["k", "c", "theta0"])
    x, _ = col.unpack(solved.w)
    return FitResult("knee_fit", {"k": float(p[0]), "c": float(p[1]), "theta0": float(p[2])},
                     ci, nodes.t, x.T, None, solved, _rms(col, solved.w))


def correct_torques(model, nodes: NodeData, *, tracking_weight: float = 1e4,
                    effort_weight: float = 1.0, smooth_weight: float = 10.0,
                    bound: float = 200.0, max_iter: int = 200) -> FitResult:
    """Smallest smooth torque changes (N m) that keep the motion on the measured one.

    Objective: tracking_weight * mean squared angle error (rad^2) + effort_weight * mean
    dtau^2 / (10 N m)^2 + smooth_weight * mean (d dtau / dt * 10 ms)^2 / (10 N m)^2.
    """
    n = len(nodes.t)
    col = LegCollocation(model, nodes, 2 * n)
    change = cs.reshape(col.p, 2, n)
    constraints = col.defects(col.xdot(change))
    scale = 10.0
    effort = cs.sumsqr(change / scale) / (2 * n)
    rate = cs.sumsqr(cs.diff(change, 1, 1) * (0.01 / col.h) / scale) / (2 * (n - 1))
    objective = tracking_weight * col.tracking() + effort_weight * effort + smooth_weight * rate
    solved = col.solve(objective, constraints, p0=np.zeros(2 * n),
                       p_bounds=(np.full(2 * n, -bound), np.full(2 * n, bound)),
                       max_iter=max_iter)
    _check(solved, "torque correction")
    x, p = col.unpack(solved.w)
    dtau = np.reshape(p, (n, 2))
    return FitResult("torque_correction", {"mean_abs_change_n_m": float(np.abs(dtau).mean()),
                                           "max_abs_change_n_m": float(np.abs(dtau).max())},
                     {}, nodes.t, x.T, dtau, solved, _rms(col, solved.w))


def fit_feedback(model, nodes: NodeData, *, perturbation_deg: float = 3.0,
                 regularization: float = 1e-10, kp_max: float = 2000.0, kd_max: float = 200.0,
                 max_iter: int = 300) -> FitResult:
    """PD gains that return a perturbed start (+perturbation on both joints) to the motion.

    The gains minimise the mean squared angle error of the perturbed trajectory plus
    ``regularization`` * (kp^2 + (10 kd)^2) (N m/rad)^2, under the uncorrected moments.
    """
    col = LegCollocation(model, nodes, 4)
    kp, kd = col.p[:2], col.p[2:]
    err_q = nodes.x_ref[:, :2].T - col.x[:2, :]
    err_v = nodes.x_ref[:, 2:].T - col.x[2:, :]
    feedback = cs.repmat(kp, 1, len(nodes.t)) * err_q + cs.repmat(kd, 1, len(nodes.t)) * err_v
    offset = np.radians(perturbation_deg) * np.array([1.0, -1.0, 0.0, 0.0])
    defects = col.defects(col.xdot(0, feedback=feedback))
    start = col.x[:, 0] - (nodes.x_ref[0] + offset)
    constraints = cs.vertcat(defects[:-4], start)
    objective = col.tracking() + regularization * (cs.sumsqr(kp) + cs.sumsqr(10 * kd))
    solved = col.solve(objective, constraints, p0=[100.0, 100.0, 10.0, 10.0],
                       p_bounds=([0, 0, 0, 0], [kp_max, kp_max, kd_max, kd_max]),
                       max_iter=max_iter)
    _check(solved, "feedback gains")
    x, p = col.unpack(solved.w)
    names = ("kp_ankle", "kp_knee", "kd_ankle", "kd_knee")
    return FitResult("feedback_gains", dict(zip(names, map(float, p), strict=True)), {},
                     nodes.t, x.T, None, solved, _rms(col, solved.w))
