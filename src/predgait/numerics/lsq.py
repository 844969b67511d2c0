"""The bounded linear least-squares step of predgait's Gauss-Newton-type solvers.

One step for the bounded IK (:mod:`predgait.kinematics.bounded_ik`, Levenberg-Marquardt)
and the shooting and swing fits (:mod:`predgait.problems.gauss_newton`): the increment
minimising a (damped) linear least-squares model inside a box, by the closed form when
it stays inside and by bounded-variable least squares (BVLS; Stark & Parker 1995,
``scipy.optimize.lsq_linear``) when a bound binds.
"""

from __future__ import annotations

import numpy as np


def bounded_step(jac: np.ndarray, r: np.ndarray, damping: float, lo: np.ndarray,
                 hi: np.ndarray) -> np.ndarray:
    """The increment dx minimising |J dx + r|^2 + damping |dx|^2 within lo <= dx <= hi.

    Args:
        jac: (m, n) Jacobian of the residuals.
        r: (m,) residuals at the current point.
        damping: Levenberg-Marquardt damping (>= 0; 0: Gauss-Newton).
        lo: (n,) lower bounds of the increment (the current point is feasible, so 0
            lies in the box: bounds on the wrong side of 0 are moved to 0).
        hi: (n,) upper bounds of the increment.

    Returns:
        (n,) increment; coordinates with no room (lo == hi == 0) do not move.
    """
    n = jac.shape[1]
    if damping > 0:
        step = np.linalg.solve(jac.T @ jac + damping * np.eye(n), -jac.T @ r)
    else:  # Gauss-Newton
        step = np.linalg.lstsq(jac, -r, rcond=None)[0]
    if np.all(step >= lo) and np.all(step <= hi):
        return step
    lo = np.minimum(lo, 0.0)    # the current point is feasible: 0 lies in the box
    hi = np.maximum(hi, 0.0)
    pinned = hi - lo <= 0.0     # at a limit with no room: lsq_linear needs lo < hi
    a = np.vstack([jac, np.sqrt(damping) * np.eye(n)])[:, ~pinned]
    b = np.concatenate([-r, np.zeros(n)])  # with damping 0 the extra rows are inert
    from scipy.optimize import lsq_linear  # heavy (1 s of imports): only when a bound binds

    out = np.zeros(n)
    out[~pinned] = lsq_linear(a, b, bounds=(lo[~pinned], hi[~pinned]), method="bvls").x
    return out
