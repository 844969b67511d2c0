"""The shank and foot swinging under a measured thigh: the quiet-phase fit's dynamics.

With the thigh's pose s = (hip centre x, z, thigh pitch) prescribed as measured, the
leg's equations (the engine's generalised coordinates of the planar leg: foot base x, z,
pitch, then ankle and knee; ADAM's M and h of the same URDF as Pinocchio)

    M(q) q'' + h(q, q') = S^T tau + J_T(q)^T w,     J_T(q) q'' + J_T'(q) q' = s''(t)

(w the hip load that holds the thigh on its measured path) are projected on the two free
joints: q'' = T a_f + c with T = [-J_b^-1 J_f; I], c = [J_b^-1 (s'' - J_T' q'); 0], and
(T^T M T) a_f = T^T (S^T tau - h - M c), which eliminates w. The foot's base coordinates
follow from s and the joint angles (planar root: translations in the lab, then pitch).
Checked against Pinocchio's equations of a leg free in the plane (tests/test_passive_swing.py).
"""

from __future__ import annotations

import numpy as np

from predgait.errors import InputError
from predgait.kinematics.clinical import clinical_joint
from predgait.problems.passive_model import PassiveModel
from predgait.problems.shooting_dynamics import passive_torques, rk4_steps, scaled_values

#: Rows of one RK4 point's input: thigh pose s, rate s' and acceleration s'' (3 each).
INPUT_ROWS = 9

_CACHE: dict = {}


def _compiled_from():
    """False with the function cache off, else its folder.

    A compiled step is kept per folder (a process that moves the cache gets that folder's
    library, not one loaded from another).
    """
    from predgait import function_cache

    return function_cache.enabled() and str(function_cache.cache_folder())


def _cached(key, build):
    if len(_CACHE) > 64:
        _CACHE.clear()
    if key not in _CACHE:
        _CACHE[key] = build()
    return _CACHE[key]


def _thigh_pose(leg):
    """CasADi ``(q (5,), v (5,)) -> (s, J_T, J_T' v)`` of the thigh pose."""
    import casadi as cs

    from predgait.models.symbolic import symbolic_model

    if leg.nq != 5 or [leg.coordinate_index(n) for n in ("ankle", "knee")] != [3, 4]:
        raise InputError(f"{leg.source}: the quiet-phase fit needs the planar leg (base x, z, "
                         "pitch, then ankle and knee).")
    hip = symbolic_model(leg).frame_position("hip_center")
    thigh = [leg.coordinate_index(c) for c in clinical_joint(leg, "hip").coordinates]
    q, v = cs.SX.sym("q", 5), cs.SX.sym("v", 5)
    pose = cs.vertcat(hip(q)[0], hip(q)[2], sum(q[i] for i in thigh))
    jac = cs.jacobian(pose, q)
    return cs.Function("thigh_pose", [q, v], [pose, jac, cs.jacobian(jac @ v, q) @ v])


def thigh_kinematics(leg, q, v, a) -> np.ndarray:
    """(n, 9) thigh pose s, rate s' and acceleration s'' at n measured states (n, 5) each."""
    pose = _cached(("pose", leg.urdf, leg.gravity), lambda: _thigh_pose(leg))
    mapped = pose.map(len(q))
    s, jac, dj_v = (np.array(m) for m in mapped(np.asarray(q).T, np.asarray(v).T))
    jac = jac.reshape(3, len(q), 5).transpose(1, 0, 2)    # (n, 3, 5)
    rate = np.einsum("nij,nj->ni", jac, v)
    acc = np.einsum("nij,nj->ni", jac, a) + dj_v.T
    return np.hstack([s.T, rate, acc])


def thigh_driven_dynamics(leg):
    """CasADi ``xdot = f(x, s9 (9,), tau (2,))`` (module docstring).

    x = (q_ankle, q_knee, v_ankle, v_knee), model coordinates; s9 = (s, s', s'') of the
    thigh; tau = ankle and knee torques, model sign (N m).
    """
    return _cached(("thigh_driven", leg.urdf, leg.gravity), lambda: _build_dynamics(leg))


def _build_dynamics(leg):
    import casadi as cs

    from predgait.models.symbolic import symbolic_model

    sym = symbolic_model(leg)
    pose = _cached(("pose", leg.urdf, leg.gravity), lambda: _thigh_pose(leg))
    thigh = [leg.coordinate_index(c) for c in clinical_joint(leg, "hip").coordinates]
    x, s9, tau = cs.SX.sym("x", 4), cs.SX.sym("s9", INPUT_ROWS), cs.SX.sym("tau", 2)
    pitch = s9[2] - sum(x[i - 3] for i in thigh if i >= 3)
    placed = pose(cs.vertcat(0, 0, pitch, x[0], x[1]), cs.SX.zeros(5))[0]
    q = cs.vertcat(s9[0] - placed[0], s9[1] - placed[1], pitch, x[0], x[1])
    jac = pose(q, cs.SX.zeros(5))[1]
    j_b, j_f = jac[:, 0:3], jac[:, 3:5]
    v = cs.vertcat(cs.solve(j_b, s9[3:6] - j_f @ x[2:4]), x[2:4])
    t = cs.vertcat(-cs.solve(j_b, j_f), cs.SX.eye(2))
    c = cs.vertcat(cs.solve(j_b, s9[6:9] - pose(q, v)[2]), cs.SX.zeros(2))
    mass = sym.mass_matrix(q)
    applied = cs.vertcat(cs.SX.zeros(3), tau)
    accel = cs.solve(t.T @ mass @ t, t.T @ (applied - sym.bias_force(q, v) - mass @ c))
    return cs.Function("thigh_driven", [x, s9, tau], [cs.vertcat(x[2:4], accel)],
                       ["x", "s9", "tau"], ["xdot"])


def step_function(leg, model: PassiveModel, substeps: int, h: float):
    """CasADi ``(x, S, u, z, knee_offset) -> (x+, S+)``: one sample interval by RK4.

    ``substeps`` classical RK4 steps of ``h`` s with the thigh inputs u (9, 2 substeps + 1)
    at the step ends and midpoints, the passive model (parameters z scaled to their
    bounds, :func:`~predgait.problems.shooting_dynamics.scaled_values`) as the only joint torque;
    S = dx / d(x0, z) (4, 4 + f) carried along (forward sensitivities). Compiled through
    :mod:`predgait.function_cache` when the cache is on (in the background: the run that
    first meets it evaluates it in CasADi's virtual machine, ~40x slower).
    """
    from predgait import function_cache

    def build():
        step = _build_step(leg, model, substeps, h)
        return function_cache.compiled(step, function_cache.key_of([step.serialize()])) \
            or step

    return _cached(("step", leg.urdf, leg.gravity, model, substeps, h,
                    _compiled_from()), build)


def _build_step(leg, model, substeps, h):
    import casadi as cs

    dynamics = thigh_driven_dynamics(leg)
    f = len(model.fitted)
    z = cs.SX.sym("z", f)
    values = scaled_values(model, z)
    x0, sens = cs.SX.sym("x", 4), cs.SX.sym("S", 4, 4 + f)
    u = cs.SX.sym("u", INPUT_ROWS, 2 * substeps + 1)
    offset = cs.SX.sym("knee_offset")

    def rhs(x, column):
        return dynamics(x, column, passive_torques(leg, model, values, x, offset))

    x = rk4_steps(rhs, x0, u, substeps, h)
    moved = cs.jacobian(x, x0) @ sens + cs.horzcat(cs.SX.zeros(4, 4), cs.jacobian(x, z))
    return cs.Function("swing_step", [x0, sens, u, z, offset], [x, moved])


def windows_function(leg, model: PassiveModel, windows: int, steps: int, substeps: int,
                     h: float):
    """CasADi ``(x0 (4, w), u, z, knee_offset) -> (X, S)`` along ``windows`` windows.

    u = (9, (2 substeps + 1) steps w) thigh inputs, window by window; X (4, steps w) the
    states after each sample interval and S (4, (4 + f) steps w) their sensitivities,
    window by window, step by step.
    """
    import casadi as cs

    def build():
        step = step_function(leg, model, substeps, h)
        f = len(model.fitted)
        mapped = step.mapaccum("window", steps, 2).map(windows)
        x0 = cs.MX.sym("x0", 4, windows)
        u = cs.MX.sym("u", INPUT_ROWS, (2 * substeps + 1) * steps * windows)
        z, offset = cs.MX.sym("z", f), cs.MX.sym("knee_offset")
        start = cs.repmat(cs.horzcat(cs.DM.eye(4), cs.DM.zeros(4, f)), 1, windows)
        states, sens = mapped(x0, start, u, cs.repmat(z, 1, steps * windows),
                              cs.repmat(offset, 1, steps * windows))
        return cs.Function("swing_windows", [x0, u, z, offset], [states, sens])

    return _cached(("windows", leg.urdf, leg.gravity, model, windows, steps, substeps, h,
                    _compiled_from()), build)
