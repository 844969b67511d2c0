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

import functools
from dataclasses import dataclass, field

import casadi as cs
import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from predgait.dynamics.forces import joint_passive_torque
from predgait.dynamics.passive import LinearSpringDamper
from predgait.errors import SolveFailed
from predgait.problems.collocation import LegCollocation, NodeData, Solved, Transcription


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
        diagnostics: Further figures (knee fit: ``sensitivity_deg`` = largest change of
            a joint angle, deg, per unit change of each parameter along the optimised
            motion; huge values mean the open-loop fit balances on the leg's instability
            and its intervals are formal only).
    """

    kind: str
    parameters: dict
    confidence95: dict
    t: np.ndarray
    x: np.ndarray
    torque_change: np.ndarray | None
    solved: Solved
    rms_deg: dict = field(default_factory=dict)
    diagnostics: dict = field(default_factory=dict)


def _knee_passive(model, params):
    """Model knee torque of the linear element (k, c, theta0 = ``params``), by the table."""
    element = LinearSpringDamper(k=params[0], c=params[1], theta0=params[2])
    return joint_passive_torque(model, "knee", element)


def _check(solved: Solved, kind: str) -> None:
    if not solved.success:
        raise SolveFailed(f"{kind}: Ipopt stopped with '{solved.status}' after "
                          f"{solved.iterations} iterations (objective {solved.objective:.4g}, "
                          f"constraint violation {solved.constraint_violation:.2e}); no "
                          "result is reported. Try a shorter window, more nodes or other "
                          "bounds.", best=solved)


def _rms(col: LegCollocation, w, nodes: NodeData) -> dict:
    x, _ = col.unpack(w)
    err = np.degrees(x[:2, :].T - nodes.x_ref[:, :2])
    return {"ankle": float(np.sqrt(np.mean(err[:, 0] ** 2))),
            "knee": float(np.sqrt(np.mean(err[:, 1] ** 2)))}


def _grid(nodes: NodeData) -> tuple[int, float]:
    return len(nodes.t) - 1, round(float(nodes.t[1] - nodes.t[0]), 12)


TRAPEZOIDAL = Transcription.TRAPEZOIDAL


@functools.lru_cache(maxsize=16)
def _knee_problem(model, n: int, h: float, max_iter: int, transcription: Transcription):
    col = LegCollocation(model, n, h, 3, transcription)
    constraints = col.defects(col.xdot(0, passive_knee=_knee_passive(model, col.p)))
    residuals = cs.vec(col.x[:2, :] - col.node["x_ref"][:2, :])
    sensitivity = cs.Function("sensitivity", [col.w, cs.vec(col.data)], [
        cs.jacobian(constraints, col.w), cs.jacobian(residuals, col.w), residuals],
        ["w", "data"], ["G_w", "R_w", "r"])
    return col, col.build(col.tracking(), constraints, max_iter=max_iter), sensitivity


def _confidence(col, sensitivity, w, nodes, names) -> tuple[dict, dict]:
    """95 % half-widths by Gauss-Newton along the dynamics: dX/dp = -G_X^-1 G_p."""
    g_w, r_w, r = sensitivity(w, col.data_values(nodes))
    g_w, r_w = scipy.sparse.csc_matrix(g_w.sparse()), scipy.sparse.csc_matrix(r_w.sparse())
    k = g_w.shape[1] - col.n_params
    dx_dp = scipy.sparse.linalg.splu(g_w[:, :k].tocsc()).solve(-g_w[:, k:].toarray())
    jac = r_w[:, :k] @ dx_dp
    r = np.array(r).ravel()
    sigma2 = float(r @ r) / max(r.size - len(names), 1)
    cov = sigma2 * np.linalg.pinv(jac.T @ jac)
    half = {n: float(1.96 * np.sqrt(max(cov[i, i], 0.0))) for i, n in enumerate(names)}
    largest = np.degrees(np.abs(np.asarray(jac)).max(axis=0))
    return half, {"sensitivity_deg": dict(zip(names, map(float, largest), strict=True)),
                  "residual_sd_deg": float(np.degrees(np.sqrt(sigma2)))}


def fit_knee(model, nodes: NodeData, *, k0: float = 10.0, c0: float = 1.0,
             k_max: float = 2000.0, c_max: float = 200.0, theta0_max_deg: float = 60.0,
             max_iter: int = 200, transcription: Transcription = TRAPEZOIDAL) -> FitResult:
    """Fit k, c and theta0 of the knee so that the synthesized motion tracks the measured.

    ``nodes`` holds every grid point (for Hermite-Simpson the midpoints too, see
    :meth:`Transcription.grid_intervals`).
    """
    col, solver, sensitivity = _knee_problem(model, *_grid(nodes), max_iter, transcription)
    limit = np.radians(theta0_max_deg)
    solved = col.solve(solver, nodes, p0=[k0, c0, 0.0],
                       p_bounds=([0.0, 0.0, -limit], [k_max, c_max, limit]))
    _check(solved, "knee fit")
    x, p = col.unpack(solved.w)
    ci, diagnostics = _confidence(col, sensitivity, solved.w, nodes, ["k", "c", "theta0"])
    return FitResult("knee_fit", {"k": float(p[0]), "c": float(p[1]), "theta0": float(p[2])},
                     ci, nodes.t, x.T, None, solved, _rms(col, solved.w, nodes), diagnostics)


@functools.lru_cache(maxsize=16)
def _correction_problem(model, n: int, h: float, weights: tuple, max_iter: int,
                        transcription: Transcription):
    tracking_weight, effort_weight, smooth_weight = weights
    col = LegCollocation(model, n, h, 2 * (n + 1), transcription)
    change = cs.reshape(col.p, 2, n + 1)
    constraints = col.defects(col.xdot(change))
    scale = 10.0
    effort = cs.sumsqr(change / scale) / (2 * (n + 1))
    rate = cs.sumsqr(cs.diff(change, 1, 1) * (0.01 / h) / scale) / (2 * n)
    objective = tracking_weight * col.tracking() + effort_weight * effort + smooth_weight * rate
    return col, col.build(objective, constraints, max_iter=max_iter)


def correct_torques(model, nodes: NodeData, *, tracking_weight: float = 1e4,
                    effort_weight: float = 1.0, smooth_weight: float = 10.0,
                    bound: float = 200.0, max_iter: int = 200,
                    transcription: Transcription = TRAPEZOIDAL) -> FitResult:
    """Smallest smooth torque changes (N m) that keep the motion on the measured one.

    Objective: tracking_weight * mean squared angle error (rad^2) + effort_weight * mean
    dtau^2 / (10 N m)^2 + smooth_weight * mean (d dtau / dt * 10 ms)^2 / (10 N m)^2.
    """
    n, h = _grid(nodes)
    col, solver = _correction_problem(model, n, h, (tracking_weight, effort_weight,
                                                    smooth_weight), max_iter, transcription)
    size = 2 * (n + 1)
    solved = col.solve(solver, nodes, p0=np.zeros(size),
                       p_bounds=(np.full(size, -bound), np.full(size, bound)))
    _check(solved, "torque correction")
    x, p = col.unpack(solved.w)
    dtau = np.reshape(p, (n + 1, 2))
    return FitResult("torque_correction", {"mean_abs_change_n_m": float(np.abs(dtau).mean()),
                                           "max_abs_change_n_m": float(np.abs(dtau).max())},
                     {}, nodes.t, x.T, dtau, solved, _rms(col, solved.w, nodes))


@functools.lru_cache(maxsize=16)
def _feedback_problem(model, n: int, h: float, perturbation: float, regularization: float,
                      max_iter: int, transcription: Transcription):
    col = LegCollocation(model, n, h, 4, transcription)
    kp, kd = col.p[:2], col.p[2:]
    ref = col.node["feedback_ref"]
    feedback = (cs.repmat(kp, 1, n + 1) * (ref[:2, :] - col.x[:2, :])
                + cs.repmat(kd, 1, n + 1) * (ref[2:, :] - col.x[2:, :]))
    offset = perturbation * np.array([1.0, -1.0, 0.0, 0.0])
    constraints = col.defects(col.xdot(0, feedback=feedback),
                              x0=col.node["x_ref"][:, 0] + offset)
    objective = col.tracking() + regularization * (cs.sumsqr(kp) + cs.sumsqr(10 * kd))
    return col, col.build(objective, constraints, max_iter=max_iter)


def fit_feedback(model, nodes: NodeData, *, perturbation_deg: float = 3.0,
                 regularization: float = 1e-10, kp_max: float = 2000.0, kd_max: float = 200.0,
                 max_iter: int = 300, transcription: Transcription = TRAPEZOIDAL) -> FitResult:
    """PD gains that return a perturbed start (ankle +, knee - perturbation) to the motion.

    With ``nodes.feedback_ref`` set and ``perturbation_deg=0`` this identifies the gains
    of a measured closed-loop response ``x_ref`` around the reference ``feedback_ref``.

    The gains minimise the mean squared angle error (rad^2) of the perturbed trajectory
    plus ``regularization`` * (kp^2 + (10 kd)^2), under the uncorrected moments.
    """
    col, solver = _feedback_problem(model, *_grid(nodes), np.radians(perturbation_deg),
                                    regularization, max_iter, transcription)
    solved = col.solve(solver, nodes, p0=[100.0, 100.0, 10.0, 10.0],
                       p_bounds=([0, 0, 0, 0], [kp_max, kp_max, kd_max, kd_max]))
    _check(solved, "feedback gains")
    x, p = col.unpack(solved.w)
    names = ("kp_ankle", "kp_knee", "kd_ankle", "kd_knee")
    return FitResult("feedback_gains", dict(zip(names, map(float, p), strict=True)), {},
                     nodes.t, x.T, None, solved, _rms(col, solved.w, nodes))
