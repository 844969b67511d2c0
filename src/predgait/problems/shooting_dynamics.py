"""The shooting fits' interval integrator on CasADi symbols (RK4 of the free leg).

Each shooting interval (:mod:`predgait.problems.shooting`) and each quiet swing window
(:mod:`predgait.problems.passive_swing_dynamics`) is integrated from a given state by
classical RK4 with the passive model's torques added to the measured drive; the residual
function of the shooting fit maps it over the intervals with its Jacobian (CasADi
forward mode).
"""

from __future__ import annotations

import functools

from predgait.kinematics.clinical import clinical_joint
from predgait.problems.passive_model import PassiveModel

#: Rows of the inputs of one RK4 point: base q, v, a (3 each), ankle and knee torque
#: (model sign), hip F_x, F_z, M_y.
INPUT_ROWS = 14


def _interval_function(leg, model: PassiveModel, substeps: int, h: float):
    """CasADi ``shoot(x0, u, z, knee_offset) -> (ankle, knee)`` at the interval end."""
    import casadi as cs

    from predgait.problems.collocation import free_dynamics

    z = cs.SX.sym("z", len(model.fitted))
    values = scaled_values(model, z)
    x0 = cs.SX.sym("x0", 4)
    u = cs.SX.sym("u", INPUT_ROWS, 2 * substeps + 1)
    offset = cs.SX.sym("knee_offset")
    dynamics = free_dynamics(leg)

    def rhs(x, column):
        return dynamics(x, column[0:3], column[3:6], column[6:9],
                        column[9:11] + passive_torques(leg, model, values, x, offset),
                        column[11:14])

    x = rk4_steps(rhs, x0, u, substeps, h)
    return cs.Function("shoot", [x0, u, z, offset], [x[:2]])


def rk4_steps(rhs, x0, u, substeps: int, h: float):
    """``substeps`` classical RK4 steps of length h (s) from x0.

    ``rhs(x, column)`` is the state rate; ``u`` holds the drive at the RK4 points
    (start, midpoint, end of each step: 2 substeps + 1 columns).
    """
    x = x0
    for s in range(substeps):
        a, m, b = u[:, 2 * s], u[:, 2 * s + 1], u[:, 2 * s + 2]
        k1 = rhs(x, a)
        k2 = rhs(x + 0.5 * h * k1, m)
        k3 = rhs(x + 0.5 * h * k2, m)
        k4 = rhs(x + h * k3, b)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


def scaled_values(model: PassiveModel, z) -> dict:
    """Key -> value of every parameter, the fitted ones lower + (upper - lower) z_i."""
    values = dict(model.values())
    for i, p in enumerate(model.fitted):
        values[p.key] = p.lower + (p.upper - p.lower) * z[i]
    return values


def passive_torques(leg, model: PassiveModel, values, x, knee_offset):
    """CasADi (2,) ankle, knee torques (model sign) of the passive model at free state x.

    x = (q_ankle, q_knee, v_ankle, v_knee) in model coordinates; the elements act on the
    clinical angles through the one joint-sign table, the knee on its anatomical angle
    (clinical - ``knee_offset``, rad), as in the decomposition fit.
    """
    import casadi as cs

    row = {"ankle": 0, "knee": 1}
    extra = [0, 0]
    for joint in model.joints:
        element = model.passive_joint(joint, values)
        offset = knee_offset if joint == "knee" else 0.0
        extra[row[joint]] = clinical_joint(leg, joint).generalized_force(
            lambda angle, rate, element=element, offset=offset:
            element.moment(angle - offset, rate), x[row[joint]], x[2 + row[joint]])
    return cs.vertcat(*extra)


def residual_function(leg, model: PassiveModel, n: int, substeps: int, h: float):
    """``residuals(z, data) -> (r (n, 2), d vec(r) / dz (2 n, f))`` for n intervals.

    ``data`` = (vec x0 (4, n), vec u (rows, points n), vec end (2, n), knee offset);
    vec(r) stacks the ankle errors of every interval, then the knee's. Compiled through
    :mod:`predgait.function_cache` when the cache is on (in the background: the run that
    first meets a trial's shape evaluates it in CasADi's virtual machine, ~15x slower).
    """
    from predgait import function_cache

    return _residual_function_built(leg, model, n, substeps, h, function_cache.enabled())


@functools.lru_cache(maxsize=8)
def _residual_function_built(leg, model, n, substeps, h, cached):
    import casadi as cs

    from predgait import function_cache

    shoot = _interval_function(leg, model, substeps, h).map(n)
    z = cs.MX.sym("z", len(model.fitted))
    x0 = cs.MX.sym("x0", 4, n)
    u = cs.MX.sym("u", INPUT_ROWS, (2 * substeps + 1) * n)
    end = cs.MX.sym("end", 2, n)
    offset = cs.MX.sym("offset")
    residual = (shoot(x0, u, cs.repmat(z, 1, n), offset) - end).T
    data = cs.vertcat(cs.vec(x0), cs.vec(u), cs.vec(end), offset)
    function = cs.Function("shooting_residuals", [z, data],
                           [residual, cs.jacobian(cs.vec(residual), z)])
    if not cached:
        return function
    return function_cache.compiled(function, function_cache.key_of([function.serialize()])) \
        or function
